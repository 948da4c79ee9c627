# SPDX-License-Identifier: BSD-3-Clause
# The console's server (issue 11): API tests in-process against a real SQLite store, Beast clients
# as robots, viewers and operators.
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
add_executable(adit_console_server_tests console/server_test.cpp)
target_link_libraries(adit_console_server_tests PRIVATE adit::console adit_test_support Boost::headers Threads::Threads
                      nlohmann_json::nlohmann_json GTest::gtest_main adit_warnings)
gtest_discover_tests(adit_console_server_tests PROPERTIES LABELS unit TIMEOUT 120 DISCOVERY_TIMEOUT 60)
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
  set_tests_properties(console_browser PROPERTIES LABELS cli TIMEOUT 300)
endif()
