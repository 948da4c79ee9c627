# SPDX-License-Identifier: BSD-3-Clause
# The console's server (issue 11): API tests against a real SQLite store, Beast clients as robots,
# viewers and operators; in-process, and (ServerTest) against the real `adit serve`.
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
add_executable(adit_console_server_tests console/server_test.cpp)
target_link_libraries(adit_console_server_tests PRIVATE adit::console adit_test_support Boost::headers Threads::Threads
                      nlohmann_json::nlohmann_json GTest::gtest_main adit_warnings)
target_compile_definitions(adit_console_server_tests PRIVATE ADIT_CONSOLE_TEST_DATA="${CMAKE_CURRENT_SOURCE_DIR}/console/data")
target_include_directories(adit_console_server_tests PRIVATE ${PROJECT_SOURCE_DIR}/console/src)  # protocol.hpp
gtest_discover_tests(adit_console_server_tests PROPERTIES LABELS unit TIMEOUT 120 DISCOVERY_TIMEOUT 60)
# The same tests against `adit serve` as a child process, its options given as flags: what the
# attacks of issue 17 meet is the program an operator runs.
if(ADIT_BUILD_TOOLS)
  add_dependencies(adit_console_server_tests adit)
  gtest_discover_tests(adit_console_server_tests TEST_PREFIX "serve/" TEST_FILTER "ServerTest.*"
                       DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS cli TIMEOUT 180 ENVIRONMENT ADIT_TEST_SERVE=${PROJECT_BINARY_DIR}/bin/adit)
endif()
# The same API tests against PostgreSQL, on the store's throw-away server (tests/console/store.cmake).
if(ADIT_PG_INITDB AND ADIT_PG_CTL AND DEFINED _pg_state)
  gtest_discover_tests(adit_console_server_tests TEST_PREFIX "postgresql/" TEST_FILTER "ServerTest.*"
                       DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS unit TIMEOUT 120 FIXTURES_REQUIRED console_postgres
                                  ENVIRONMENT ADIT_TEST_POSTGRES_STATE=${_pg_state})
endif()

# A robot (or ten) speaking the protocol to a running `adit serve`: the browser test's robot and
# the console's latency / throughput figures.
add_executable(adit_console_feed console/console_feed.cpp)
target_include_directories(adit_console_feed PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(adit_console_feed PRIVATE Boost::headers Threads::Threads nlohmann_json::nlohmann_json adit_warnings)

# The page in headless Chromium against a real `adit serve` on the bundled district map.
if(EXISTS /usr/bin/chromium AND ADIT_BUILD_TOOLS)
  add_test(NAME console_browser
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/console/browser_console.sh $<TARGET_FILE:adit>
                   $<TARGET_FILE:adit_console_feed> ${PROJECT_SOURCE_DIR}/maps/district.yaml
                   ${CMAKE_CURRENT_BINARY_DIR}/console_browser $<TARGET_FILE:animation_page_demo>)
  set_tests_properties(console_browser PROPERTIES LABELS cli TIMEOUT 600
                       ENVIRONMENT ADIT_TEST_SLOWDOWN=${ADIT_TEST_SLOWDOWN})
endif()
# The whole loop with the centre SIGKILLed and restarted mid-run: every message stored once.
if(ADIT_BUILD_TOOLS)
  add_test(NAME console_fault_restart
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/console/fault_console.sh $<TARGET_FILE:adit>
                   ${PROJECT_SOURCE_DIR}/maps/district.yaml ${CMAKE_CURRENT_BINARY_DIR}/console_fault)
  set_tests_properties(console_fault_restart PROPERTIES LABELS cli TIMEOUT 300
                       ENVIRONMENT ADIT_TEST_SLOWDOWN=${ADIT_TEST_SLOWDOWN})
endif()

# `adit serve` refuses bad input with exit 2 and a message naming it, before serving anything.
if(ADIT_BUILD_TOOLS)
  set(_serve_cli ${PROJECT_SOURCE_DIR}/tests/tools/run_cli.cmake)
  set(_small ${PROJECT_SOURCE_DIR}/tests/tools/data/small.yaml)
  set(_serve_out ${CMAKE_CURRENT_BINARY_DIR}/console_cli)
  file(MAKE_DIRECTORY ${_serve_out})
  function(adit_serve_cli_test name code stderr)
    add_test(NAME cli_serve_${name}
             COMMAND ${CMAKE_COMMAND} "-DCMD=$<TARGET_FILE:adit>;serve;${ARGN}" -DEXPECT_CODE=${code}
                     "-DEXPECT_STDERR=${stderr}" -P ${_serve_cli}
             WORKING_DIRECTORY ${_serve_out})
    set_tests_properties(cli_serve_${name} PROPERTIES LABELS cli)
  endfunction()
  adit_serve_cli_test(help 0 "" --help)
  adit_serve_cli_test(no_map 2 "--map is required")
  adit_serve_cli_test(missing_map 2 "nope.yaml: no such file" --map ${_serve_out}/nope.yaml)
  adit_serve_cli_test(bad_listen 2 "'localhost' is not an IP address" --map ${_small} --listen localhost:8080)
  adit_serve_cli_test(bad_port 2 "the port must be 0-65535" --map ${_small} --listen 127.0.0.1:70000)
  adit_serve_cli_test(short_token 2 "short_token.txt:1: the token is shorter than 16 characters"
                      --map ${_small} --token-file ${CMAKE_CURRENT_SOURCE_DIR}/console/data/short_token.txt)
  adit_serve_cli_test(empty_token 2 "empty_token.txt: no token in the file"
                      --map ${_small} --token-file ${CMAKE_CURRENT_SOURCE_DIR}/console/data/empty_token.txt)
  adit_serve_cli_test(bad_db 2 "mysql" --map ${_small} --db mysql://centre/adit --listen 127.0.0.1:0)
  # Credentials and origins (issue 17): refused before the map loads, naming the file and line.
  set(_data ${CMAKE_CURRENT_SOURCE_DIR}/console/data)
  adit_serve_cli_test(robot_tokens_duplicate 2 "robot_tokens_duplicate.txt:4: robot 'r1' again"
                      --map ${_small} --robot-tokens ${_data}/robot_tokens_duplicate.txt)
  adit_serve_cli_test(robot_tokens_short 2 "robot_tokens_short.txt:1: the token is shorter than 16 characters"
                      --map ${_small} --robot-tokens ${_data}/robot_tokens_short.txt)
  adit_serve_cli_test(robot_tokens_same 2 "robot_tokens_same.txt:2: the same token as an earlier robot's"
                      --map ${_small} --robot-tokens ${_data}/robot_tokens_same.txt)
  adit_serve_cli_test(robot_tokens_operator 2 "robot token for 'r1': the same as another robot's or the operator's"
                      --map ${_small} --token-file ${_data}/robot_r1_token.txt --robot-tokens ${_data}/robot_tokens_r1.txt)
  adit_serve_cli_test(bad_origin 2 "--allow-origin 'ops.example': expected SCHEME://HOST"
                      --map ${_small} --allow-origin ops.example)
  # Quotas (issue 17): each bad value named, before the map loads.
  adit_serve_cli_test(zero_rate 2 "--robot-rate must be > 0 messages/s" --map ${_small} --robot-rate 0)
  adit_serve_cli_test(negative_rate 2 "--robot-rate must be > 0 messages/s" --map ${_small} --robot-rate=-5)
  adit_serve_cli_test(bad_bandwidth 2 "--robot-bandwidth: " --map ${_small} --robot-bandwidth fast)
  adit_serve_cli_test(zero_bandwidth 2 "--robot-bandwidth: memory size '0'" --map ${_small} --robot-bandwidth 0)
  adit_serve_cli_test(tiny_store_quota 2 "--robot-store-quota must be at least 1 MiB" --map ${_small}
                      --robot-store-quota 100k)
  adit_serve_cli_test(tiny_viewer_queue 2 "a viewer's queue must hold at least 1 MiB" --map ${_small}
                      --viewer-queue 100k)
  adit_serve_cli_test(bad_viewer_queue 2 "--viewer-queue: " --map ${_small} --viewer-queue lots)
endif()
