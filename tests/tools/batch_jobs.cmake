# SPDX-License-Identifier: BSD-3-Clause
# `adit simulate --batch`: the same seed gives the same table with 1 and 2 workers. The step-time
# columns (8, 9) are wall-clock measurements and are left out of the comparison; every other
# column must match byte for byte. Arrivals must not have collided (exit 0 says so).
# `--first` re-runs rows of the table: runs 2 and 3 alone give the same rows.
# Args: ADIT, MAP, OUT, N (>= 4).
foreach(jobs 1 2)
  execute_process(COMMAND ${ADIT} simulate -q --map ${MAP} --batch ${N} --seed 7 --jobs ${jobs} --t-max 90 --max-separation 40
                          --csv ${OUT}/batch_j${jobs}.csv --out ${OUT}/batch_j${jobs}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "--jobs ${jobs}: exit ${rc}: ${err}")
  endif()
  file(STRINGS ${OUT}/batch_j${jobs}.csv lines)
  set(table_${jobs} "")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "^([^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,)[^,]*,[^,]*," "\\1" kept "${line}")
    string(APPEND table_${jobs} "${kept}\n")
  endforeach()
endforeach()
if(NOT table_1 STREQUAL table_2)
  message(FATAL_ERROR "tables differ:\n--jobs 1:\n${table_1}--jobs 2:\n${table_2}")
endif()
execute_process(COMMAND ${ADIT} simulate -q --map ${MAP} --batch 2 --first 2 --seed 7 --jobs 1 --t-max 90 --max-separation 40
                        --csv ${OUT}/batch_first2.csv --out ${OUT}/batch_first2.json
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "--first 2: exit ${rc}: ${err}")
endif()
file(STRINGS ${OUT}/batch_first2.csv lines)
list(REMOVE_AT lines 0)  # the header
set(table_first "\n")
foreach(line IN LISTS lines)
  string(REGEX REPLACE "^([^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,)[^,]*,[^,]*," "\\1" kept "${line}")
  string(APPEND table_first "${kept}\n")
endforeach()
string(REGEX MATCH "\n2,[^\n]*\n3,[^\n]*\n" rows_2_3 "${table_1}")
if(rows_2_3 STREQUAL "" OR NOT rows_2_3 STREQUAL table_first)
  message(FATAL_ERROR "--first 2 --batch 2 differs from rows 2 and 3:${table_first}vs${rows_2_3}")
endif()
file(READ ${OUT}/batch_j2.json summary)
if(NOT summary MATCHES "\"collisions_among_arrivals\": 0" OR NOT summary MATCHES "\"arrivals_beyond_tolerance\": 0")
  message(FATAL_ERROR "dishonest arrivals:\n${summary}")
endif()
message(STATUS "same table with 1 and 2 workers:\n${table_1}")
