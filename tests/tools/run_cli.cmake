# SPDX-License-Identifier: BSD-3-Clause
# Runs one CLI command and checks its exit code and output; used by adit_cli_test().
# -DCMD=<;-list> -DEXPECT_CODE=<n> [-DEXPECT_STDOUT=<regex>] [-DEXPECT_STDERR=<regex>]
# [-DEXPECT_FILE=<path that must exist>] [-DEXPECT_NO_FILE=<path that must not exist>]
execute_process(COMMAND ${CMD} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 600)
message("exit code: ${code}\n--- stdout ---\n${out}\n--- stderr ---\n${err}")
if(NOT "${code}" STREQUAL "${EXPECT_CODE}")
  message(FATAL_ERROR "expected exit code ${EXPECT_CODE}, got ${code}")
endif()
if(DEFINED EXPECT_STDOUT AND NOT out MATCHES "${EXPECT_STDOUT}")
  message(FATAL_ERROR "stdout does not match: ${EXPECT_STDOUT}")
endif()
if(DEFINED EXPECT_STDERR AND NOT err MATCHES "${EXPECT_STDERR}")
  message(FATAL_ERROR "stderr does not match: ${EXPECT_STDERR}")
endif()
if(DEFINED EXPECT_FILE AND NOT EXISTS "${EXPECT_FILE}")
  message(FATAL_ERROR "expected file ${EXPECT_FILE} was not written")
endif()
if(DEFINED EXPECT_NO_FILE AND EXISTS "${EXPECT_NO_FILE}")
  message(FATAL_ERROR "file ${EXPECT_NO_FILE} must not exist")
endif()
