# SPDX-License-Identifier: BSD-3-Clause
# The operations console end to end (issue 11): a real `adit serve` and a real
# `adit simulate --live` as child processes on maps/scenarios/district_rescue.yaml, checked
# through the HTTP API by tests/console/integration_e2e.py (python3 stdlib): the run undisturbed,
# the server killed (SIGKILL) and restarted mid-run, the robot's connection cut by a TCP proxy,
# operator commands (a goal in rock refused, a block that makes the robot replan), the server
# killed for good (the run says what it lost and exits 1), and the kill
# with PostgreSQL (a throw-away server, only where initdb/pg_ctl exist). Telemetry every 0.5 s of
# mission time: about 700 messages per test.
find_package(Python3 COMPONENTS Interpreter)
if(TARGET adit AND Python3_Interpreter_FOUND)
  set(_e2e ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/integration_e2e.py --adit $<TARGET_FILE:adit>
           --map ${PROJECT_SOURCE_DIR}/maps/district.yaml
           --scenario ${PROJECT_SOURCE_DIR}/maps/scenarios/district_rescue.yaml --live-period 0.5
           --slowdown ${ADIT_TEST_SLOWDOWN})
  set(_e2e_dir ${CMAKE_CURRENT_BINARY_DIR}/console_e2e)
  # fault;database;live speed (0: as fast as it goes). A kill needs the run to outlast the
  # restart (about 3 s to load the map): 30x gives 10 s of driving. The commands run holds the
  # robot at its start (--live-hold) until the operator's block is executed, so it needs no pace.
  foreach(spec "none;sqlite;0" "kill;sqlite;30" "drop;sqlite;40" "commands;sqlite;0" "gone;sqlite;30")
    list(GET spec 0 fault)
    list(GET spec 1 db)
    list(GET spec 2 speed)
    add_test(NAME console_e2e_${fault}_${db}
             COMMAND ${_e2e} --fault ${fault} --db ${db} --live-speed ${speed} --workdir ${_e2e_dir}/${fault}_${db})
    set_tests_properties(console_e2e_${fault}_${db} PROPERTIES LABELS "cli;scenario" TIMEOUT 300)
  endforeach()

  # PostgreSQL: the store's throw-away server (store.cmake's fixture console_postgres, registered
  # only where initdb/pg_ctl exist). The store's tests use databases of their own; this one the
  # server's default database, robot ids unique per run.
  if(TEST console_postgres_start)
    add_test(NAME console_e2e_kill_postgresql
             COMMAND ${_e2e} --fault kill --db postgresql --pg-state ${CMAKE_CURRENT_BINARY_DIR}/console_postgres
                     --live-speed 30 --workdir ${_e2e_dir}/kill_postgresql)
    set_tests_properties(console_e2e_kill_postgresql PROPERTIES LABELS "cli;scenario" TIMEOUT 300
                         FIXTURES_REQUIRED console_postgres)
  endif()
endif()

# The load figures (10 robots at 50 Hz, latency to a viewer, rows/s, RSS): a client program run
# by hand against a running `adit serve`, never by CTest (see the file's head).
if(ADIT_BUILD_BENCHMARKS)
  find_package(Boost 1.74 REQUIRED)
  find_package(Threads REQUIRED)
  find_package(nlohmann_json 3 REQUIRED)
  add_executable(adit_console_load ${CMAKE_CURRENT_LIST_DIR}/load_client.cpp)
  target_link_libraries(adit_console_load PRIVATE adit::console Boost::headers Threads::Threads
                        nlohmann_json::nlohmann_json adit_warnings)
endif()
