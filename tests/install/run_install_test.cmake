# SPDX-License-Identifier: BSD-3-Clause
# Installs the build tree into a scratch prefix, configures and builds the consumer project
# against it, and runs it. Arguments: BUILD_DIR, SOURCE_DIR (the consumer), WORK_DIR, GENERATOR,
# CONSUMER_FLAGS (compile and link flags the installed tree was built with, e.g. the sanitizers),
# MAP (the map the Navigator consumer replans on).
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}"
    "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
run(${WORK_DIR}/build/navigator_consumer ${MAP})
message(STATUS "installed adit: find_package, the adit::local and adit::fusion consumers built and ran")
