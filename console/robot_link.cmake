# SPDX-License-Identifier: BSD-3-Clause
# The robot link (issue 11): the robot's WebSocket client to the console (Boost.Beast, header-only
# from Debian's libboost1.74-dev; its I/O thread needs Threads) speaking protocol.md's JSON.
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
target_sources(adit_console PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/robot_link.cpp ${CMAKE_CURRENT_LIST_DIR}/src/messages.cpp)
target_link_libraries(adit_console PRIVATE Boost::headers Threads::Threads nlohmann_json::nlohmann_json)
