# SPDX-License-Identifier: BSD-3-Clause
# Builds the API reference (target adit_api_docs, Doxygen) and checks it: no Doxygen warning,
# and the pages a robot developer starts from exist. Argument: BUILD_DIR.
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BUILD_DIR} --target adit_api_docs
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "adit_api_docs failed (${rc}):\n${out}\n${err}")
endif()
if("${out}${err}" MATCHES "warning")
  message(FATAL_ERROR "Doxygen warned:\n${out}\n${err}")
endif()
foreach(page index classadit_1_1fusion_1_1Navigator classadit_1_1local_1_1LocalPlanner
             classadit_1_1global_1_1GlobalPlanner classadit_1_1map_1_1DistanceField)
  if(NOT EXISTS ${BUILD_DIR}/api/html/${page}.html)
    message(FATAL_ERROR "the API reference has no ${page}.html")
  endif()
endforeach()
message(STATUS "API reference: ${BUILD_DIR}/api/html/index.html")
