# SPDX-License-Identifier: BSD-3-Clause
# Runs one `adit plan` command twice (two processes) with --out A and --out B and requires the two
# result files to hold the same path, byte for byte (the timings in the JSON differ, so the CSV
# is compared). -DCMD=<;-list without --out> -DOUT_A=<file.csv> -DOUT_B=<file.csv>
foreach(out ${OUT_A} ${OUT_B})
  file(REMOVE ${out})
  execute_process(COMMAND ${CMD} --out ${out} RESULT_VARIABLE code ERROR_VARIABLE err TIMEOUT 300)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "exit code ${code}: ${err}")
  endif()
endforeach()
file(READ ${OUT_A} a)
file(READ ${OUT_B} b)
if(NOT a STREQUAL b)
  message(FATAL_ERROR "two runs with the same seed differ:\n${a}\n---\n${b}")
endif()
message("same path twice:\n${a}")
