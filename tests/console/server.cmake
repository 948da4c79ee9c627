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
