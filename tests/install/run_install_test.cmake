# SPDX-License-Identifier: BSD-3-Clause
# Installs the build tree into a scratch prefix and moves the prefix elsewhere (an installed adit
# must not depend on where it was installed, nor name paths of the machine it was built on), checks
# that the installed public headers stand alone (each opens with a paragraph on its role; no issue
# numbers, no paths into adit's repository), then configures and builds the consumer project
# against the moved prefix and runs it. Arguments: BUILD_DIR, SOURCE_DIR (the consumer), WORK_DIR,
# GENERATOR, CONSUMER_FLAGS (compile and link flags the installed tree was built with, e.g. the
# sanitizers), MAP (the map the Navigator consumer replans on).
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/installed)
file(RENAME ${WORK_DIR}/installed ${WORK_DIR}/prefix)
set(prefix ${WORK_DIR}/prefix)

# The package: all five libraries exported, their third-party dependencies named by imported
# target (found again by find_dependency), no absolute path.
file(GLOB targets_files ${prefix}/lib*/cmake/adit/aditTargets*.cmake)
if(NOT targets_files)
  message(FATAL_ERROR "no aditTargets*.cmake under ${prefix}/lib*/cmake/adit")
endif()
set(exported "")
foreach(f IN LISTS targets_files)
  file(READ ${f} text)
  string(APPEND exported "${text}")
  foreach(path /usr/ ${BUILD_DIR} ${WORK_DIR})
    string(FIND "${text}" "${path}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "${f} names the path ${path}: the installed package would not move")
    endif()
  endforeach()
endforeach()
foreach(lib map global local fusion sim)
  if(NOT exported MATCHES "add_library\\(adit::${lib} STATIC IMPORTED\\)")
    message(FATAL_ERROR "the installed package does not export adit::${lib}")
  endif()
endforeach()

# The headers: a role paragraph first, and nothing that points into the repository.
file(GLOB_RECURSE headers RELATIVE ${prefix}/include ${prefix}/include/adit/*.hpp)
list(LENGTH headers n_headers)
if(n_headers LESS 40)
  message(FATAL_ERROR "only ${n_headers} public headers installed under ${prefix}/include/adit")
endif()
set(problems "")
foreach(h IN LISTS headers)
  file(READ ${prefix}/include/${h} text)
  if(NOT text MATCHES "^// SPDX-License-Identifier: [^\n]+\n#pragma once\n/// @file\n/// [A-Za-z`*(]")
    string(APPEND problems "${h}: does not open with '/// @file' and a paragraph on its role\n")
  endif()
  foreach(bad "[Ii]ssues? #?[0-9]" "[^&]#[0-9]" "shared/" "spec[/ ]" "tests?/" "tools/" "console/"
              "docs/" "README" "[A-Za-z_]\\.md[^a-z]")
    if(text MATCHES "${bad}")
      string(APPEND problems "${h}: '${CMAKE_MATCH_0}' (an issue number or a path into the repository)\n")
    endif()
  endforeach()
endforeach()
if(problems)
  message(FATAL_ERROR "installed headers that do not stand alone:\n${problems}")
endif()
message(STATUS "${n_headers} installed headers open with their role and point nowhere into the repository")

run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${prefix} "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}"
    "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
message(STATUS "consumer: ${out}")
run(${WORK_DIR}/build/navigator_consumer ${MAP})
message(STATUS "navigator_consumer: ${out}")
run(${WORK_DIR}/build/sim_consumer)
message(STATUS "sim_consumer: ${out}")
message(STATUS "installed adit (moved after the install): find_package, the adit::local, adit::fusion and adit::sim consumers built and ran")
