# SPDX-License-Identifier: BSD-3-Clause
# The console's server (issue 11): Boost.Beast HTTP + WebSocket, the message checks, the roadway
# mesh, and the page (console/web) embedded at build time. Beast and Asio are header-only in
# Debian's libboost1.74-dev.
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)

set(ADIT_CONSOLE_WEB
  ${CMAKE_CURRENT_SOURCE_DIR}/web/index.html
  ${CMAKE_CURRENT_SOURCE_DIR}/web/console.js
  ${CMAKE_CURRENT_SOURCE_DIR}/web/console.css)
# The list goes to the script '|'-separated: a ';' in a custom command splits the argument.
string(REPLACE ";" "|" ADIT_CONSOLE_WEB_ARG "${ADIT_CONSOLE_WEB}")
set(ADIT_CONSOLE_WEB_CPP ${CMAKE_CURRENT_BINARY_DIR}/generated/web_assets.cpp)
add_custom_command(OUTPUT ${ADIT_CONSOLE_WEB_CPP}
  COMMAND ${CMAKE_COMMAND} -DOUT=${ADIT_CONSOLE_WEB_CPP} "-DFILES=${ADIT_CONSOLE_WEB_ARG}"
          -P ${CMAKE_CURRENT_SOURCE_DIR}/embed_web.cmake
  DEPENDS ${ADIT_CONSOLE_WEB} ${CMAKE_CURRENT_SOURCE_DIR}/embed_web.cmake
  COMMENT "Embedding the console's page" VERBATIM)

# server.cpp: options and the Server's life; transport.cpp: connections; routes.cpp: HTTP;
# robot_stream.cpp: what robots send; writer.cpp: the database thread; alarms.cpp: what the centre
# raises (server_impl.hpp: their state).
target_sources(adit_console PRIVATE
  src/server.cpp
  src/transport.cpp
  src/routes.cpp
  src/robot_stream.cpp
  src/writer.cpp
  src/alarms.cpp
  src/protocol.cpp
  src/mesh.cpp
  ${ADIT_CONSOLE_WEB_CPP})
target_link_libraries(adit_console PRIVATE Boost::headers Threads::Threads nlohmann_json::nlohmann_json)
