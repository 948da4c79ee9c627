# SPDX-License-Identifier: BSD-3-Clause
# The data exchange centre's database (issue 11): SQLite (embedded) and PostgreSQL (libpqxx), both
# private to adit::console: its users see store.hpp only.
find_package(SQLite3 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(PQXX REQUIRED IMPORTED_TARGET libpqxx libpq)
target_sources(adit_console PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/src/store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/store_sqlite.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/store_postgres.cpp)
target_link_libraries(adit_console PRIVATE SQLite::SQLite3 PkgConfig::PQXX)
