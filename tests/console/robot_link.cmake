# SPDX-License-Identifier: BSD-3-Clause
# The robot link against a minimal WebSocket centre written in the test (Boost.Beast): resend
# after a dropped connection and a restarted centre, command dedup, refusals.
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
add_executable(adit_robot_link_tests ${CMAKE_CURRENT_LIST_DIR}/robot_link_test.cpp)
target_link_libraries(adit_robot_link_tests PRIVATE adit::console adit_test_support Boost::headers Threads::Threads
                      nlohmann_json::nlohmann_json GTest::gtest_main adit_warnings)
gtest_discover_tests(adit_robot_link_tests PROPERTIES LABELS unit DISCOVERY_TIMEOUT 60)
# `adit simulate --live` end to end against the same test centre.
if(TARGET adit)
  target_compile_definitions(adit_robot_link_tests PRIVATE ADIT_TOOL_PATH="$<TARGET_FILE:adit>")
  add_dependencies(adit_robot_link_tests adit)
endif()
