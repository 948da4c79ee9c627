# SPDX-License-Identifier: BSD-3-Clause
# The operations console end to end (issue 11): a real `adit serve` and a real
# `adit simulate --live` as child processes, checked through the HTTP API by
# tests/console/integration_e2e.py (python3 stdlib): the run undisturbed, the server killed
# (SIGKILL) and restarted mid-run, the robot's connection cut by a TCP proxy, the kill with
# PostgreSQL (a throw-away server, only where initdb/pg_ctl exist), and operator commands.
find_package(Python3 COMPONENTS Interpreter)
if(TARGET adit AND Python3_Interpreter_FOUND)
  set(_e2e ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/integration_e2e.py --adit $<TARGET_FILE:adit>
           --map ${PROJECT_SOURCE_DIR}/maps/district.yaml)
  set(_e2e_dir ${CMAKE_CURRENT_BINARY_DIR}/console_e2e)
  # name, fault, database, scenario, live speed
  foreach(spec "none;sqlite;district_rescue;10" "kill;sqlite;district_rescue;10" "drop;sqlite-normal;district_rescue;0"
               "commands;sqlite-normal;district_rescue;4")
    list(GET spec 0 fault)
    list(GET spec 1 db)
    list(GET spec 2 scenario)
    list(GET spec 3 speed)
    add_test(NAME console_e2e_${fault}_${db}
             COMMAND ${_e2e} --scenario ${PROJECT_SOURCE_DIR}/maps/scenarios/${scenario}.yaml --fault ${fault}
                     --db ${db} --live-speed ${speed} --workdir ${_e2e_dir}/${fault}_${db})
    set_tests_properties(console_e2e_${fault}_${db} PROPERTIES LABELS "cli;scenario" TIMEOUT 300)
  endforeach()
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
