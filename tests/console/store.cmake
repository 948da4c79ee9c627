# SPDX-License-Identifier: BSD-3-Clause
# The store's tests (issue 11): one suite over both backends. The PostgreSQL cases run against a
# throw-away server that a CTest fixture starts (initdb + pg_ctl in a temp dir, loopback, as the
# `postgres` account when run as root) and stops by PID; they are registered only where
# PostgreSQL's server binaries are installed, so a machine without them still passes.
find_package(SQLite3 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(PQXX REQUIRED IMPORTED_TARGET libpqxx libpq)
add_executable(adit_console_store_tests ${CMAKE_CURRENT_LIST_DIR}/store_test.cpp)
target_link_libraries(adit_console_store_tests PRIVATE adit::console SQLite::SQLite3 PkgConfig::PQXX
                      GTest::gtest_main adit_warnings)
gtest_discover_tests(adit_console_store_tests TEST_FILTER "-*/postgresql:*Postgresql*"
                     PROPERTIES LABELS unit DISCOVERY_TIMEOUT 60)

find_program(ADIT_PG_INITDB initdb PATHS /usr/lib/postgresql/15/bin NO_DEFAULT_PATH)
find_program(ADIT_PG_CTL pg_ctl PATHS /usr/lib/postgresql/15/bin NO_DEFAULT_PATH)
if(ADIT_PG_INITDB AND ADIT_PG_CTL)
  set(_pg_state ${CMAKE_CURRENT_BINARY_DIR}/console_postgres)
  get_filename_component(_pg_bindir ${ADIT_PG_INITDB} DIRECTORY)
  add_test(NAME console_postgres_start
           COMMAND env PG_BINDIR=${_pg_bindir} sh ${CMAKE_CURRENT_LIST_DIR}/postgres_fixture.sh start ${_pg_state})
  add_test(NAME console_postgres_stop
           COMMAND sh ${CMAKE_CURRENT_LIST_DIR}/postgres_fixture.sh stop ${_pg_state})
  set_tests_properties(console_postgres_start PROPERTIES FIXTURES_SETUP console_postgres LABELS unit TIMEOUT 120)
  set_tests_properties(console_postgres_stop PROPERTIES FIXTURES_CLEANUP console_postgres LABELS unit TIMEOUT 60)
  gtest_discover_tests(adit_console_store_tests TEST_FILTER "*/postgresql:*Postgresql*"
                       DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS unit FIXTURES_REQUIRED console_postgres
                                  ENVIRONMENT ADIT_TEST_POSTGRES_STATE=${_pg_state})
endif()

# The rows-per-second figures (Google Benchmark, never run by CTest): see the file's head.
if(ADIT_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
  add_executable(adit_console_store_bench ${CMAKE_CURRENT_LIST_DIR}/../bench/console_store_bench.cpp)
  target_link_libraries(adit_console_store_bench PRIVATE adit::console benchmark::benchmark adit_warnings)
endif()
