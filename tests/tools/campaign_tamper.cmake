# SPDX-License-Identifier: BSD-3-Clause
# `adit campaign merge` believes no number in a shard's JSON (issue 17): it recomputes them from
# the shard's CSV rows, checked against the SHA-256 the JSON records. Each attack below edits a
# copy of a real shard the way a user (or a script gone wrong) would; merge must refuse it with
# exit 2, name the file and the field, and write nothing (no report, no --csv, no --html).
# Uses the shards of campaign_shards.cmake (fixture campaign_shards). Args: ADIT, OUT, SEED.
set(C ${OUT}/campaign)
set(T ${C}/tamper)
file(REMOVE_RECURSE ${T})
file(MAKE_DIRECTORY ${T})

# The untouched shards merge (the baseline the attacks are measured against).
execute_process(COMMAND ${ADIT} campaign merge -q ${C}/m2 --out ${T}/honest.json RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0 AND NOT rc EQUAL 1)
  message(FATAL_ERROR "the honest shards do not merge: exit ${rc}:\n${err}")
endif()

file(READ ${C}/m2/shard-0-of-2.json json0)
file(READ ${C}/m2/shard-0-of-2.csv csv0)
file(READ ${C}/m2/shard-1-of-2.json json1)

# A copy of m2 in ${T}/NAME with shard 0's JSON and CSV replaced; shard 1 untouched.
function(attack name json csv)
  file(MAKE_DIRECTORY ${T}/${name})
  file(WRITE ${T}/${name}/shard-0-of-2.json "${json}")
  file(WRITE ${T}/${name}/shard-0-of-2.csv "${csv}")
  file(COPY ${C}/m2/shard-1-of-2.json ${C}/m2/shard-1-of-2.csv DESTINATION ${T}/${name})
endfunction()

function(refused name expect)
  set(outs ${T}/${name}/report.json ${T}/${name}/rows.csv ${T}/${name}/report.html)
  execute_process(COMMAND ${ADIT} campaign merge ${ARGN} --out ${T}/${name}/report.json --csv ${T}/${name}/rows.csv
                          --html ${T}/${name}/report.html
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "${name}: expected exit 2, got ${rc}:\n${err}")
  endif()
  if(NOT err MATCHES "${expect}")
    message(FATAL_ERROR "${name}: stderr does not match '${expect}':\n${err}")
  endif()
  foreach(f IN LISTS outs)
    if(EXISTS ${f})
      message(FATAL_ERROR "${name}: ${f} was written")
    endif()
  endforeach()
  message(STATUS "${name}: refused:\n${err}")
endfunction()

# The digest the JSON records for its CSV, replaced by the digest of `csv` (an attacker who
# edits both files).
function(with_digest_of csv json var)
  string(SHA256 digest "${csv}")
  string(REGEX REPLACE "\"csv_sha256\": \"[0-9a-f]+\"" "\"csv_sha256\": \"${digest}\"" j "${json}")
  set(${var} "${j}" PARENT_SCOPE)
endfunction()

# 1. A count edited in the JSON: arrived 1000000 (the issue's success rate of 250000).
string(REGEX REPLACE "(\"outcomes\": {[\n ]*\"arrived\": )[0-9]+" "\\11000000" j "${json0}")
attack(arrived "${j}" "${csv0}")
refused(arrived "shard-0-of-2.json: /stats/counts/outcomes/arrived is 1000000, its rows give [0-9]+" ${T}/arrived)

# 2. A sum at INT64_MAX.
string(REGEX REPLACE "\"path_length_mm_sum\": [0-9]+" "\"path_length_mm_sum\": 9223372036854775807" j "${json0}")
attack(int64_max "${j}" "${csv0}")
refused(int64_max "/stats/counts/path_length_mm_sum is 9223372036854775807, its rows give [0-9]+" ${T}/int64_max)

# 3. A count beyond INT64_MAX (2^64 - 1): compared as a number, never wrapped to -1.
string(REGEX REPLACE "\"replans\": [0-9]+" "\"replans\": 18446744073709551615" j "${json0}")
attack(uint64_max "${j}" "${csv0}")
refused(uint64_max "/stats/counts/replans is 18446744073709551615, its rows give [0-9]+" ${T}/uint64_max)

# 4. A CSV row edited (scenario 0 said to have errored): its digest no longer matches.
string(REGEX REPLACE "\n0,([0-9]+),[a-z_]+," "\n0,\\1,error," c "${csv0}")
if(c STREQUAL csv0)
  message(FATAL_ERROR "the row edit changed nothing:\n${csv0}")
endif()
attack(row_edited "${json0}" "${c}")
refused(row_edited "shard-0-of-2.csv: SHA-256 [0-9a-f]+, but [^\n]*shard-0-of-2.json recorded [0-9a-f]+: the rows were changed" ${T}/row_edited)

# 5. The same edit with the digest recomputed: the counts recomputed from the rows disagree.
with_digest_of("${c}" "${json0}" j)
attack(row_and_digest "${j}" "${c}")
refused(row_and_digest "shard-0-of-2.json: /stats/counts/[a-z_/]+ is [0-9]+, its rows give [0-9]+" ${T}/row_and_digest)

# 6. A row's seed changed (with its digest): the campaign seed gives that index another seed.
string(REGEX REPLACE "\n0,[0-9]+," "\n0,12345," c "${csv0}")
with_digest_of("${c}" "${json0}" j)
attack(row_seed "${j}" "${c}")
refused(row_seed "shard-0-of-2.csv:2: scenario 0 has seed 12345; campaign seed ${SEED} gives it [0-9]+" ${T}/row_seed)

# 7. Shard 0's content relabelled as shard 1 (index and CSV name edited): its rows are not shard
#    1's scenarios.
string(REGEX REPLACE "(\"shard\": {[\n ]*\"index\": )0" "\\11" j "${json0}")
string(REPLACE "shard-0-of-2.csv" "shard-1-of-2.csv" j "${j}")
file(MAKE_DIRECTORY ${T}/relabelled)
file(WRITE ${T}/relabelled/shard-1-of-2.json "${j}")
file(WRITE ${T}/relabelled/shard-1-of-2.csv "${csv0}")
file(COPY ${C}/m2/shard-0-of-2.json ${C}/m2/shard-0-of-2.csv DESTINATION ${T}/relabelled)
refused(relabelled "relabelled/shard-1-of-2.csv:2: scenario 0 is not one of shard 1 of 2 \\(i mod 2 == 1" ${T}/relabelled)

# 8. A malformed failure list (an entry that is not an object): bad input, not an internal error.
string(REPLACE "\"failures\": []" "\"failures\": [7]" j "${json0}")
string(REPLACE "\"failures\": [\n" "\"failures\": [7,\n" j "${j}")
attack(failures "${j}" "${csv0}")
refused(failures "shard-0-of-2.json: /failures(/0: expected an object| has 1 entries, its rows give 0)" ${T}/failures)

# 9. A failure entry's index as a string (the issue's "internal error").
string(REGEX REPLACE "(\"failures\": \\[[\n ]*{[\n ]*\"index\": )([0-9]+)" "\\1\"\\2\"" j "${json1}")
if(NOT j STREQUAL json1)
  file(MAKE_DIRECTORY ${T}/failure_index)
  file(WRITE ${T}/failure_index/shard-1-of-2.json "${j}")
  file(COPY ${C}/m2/shard-1-of-2.csv ${C}/m2/shard-0-of-2.json ${C}/m2/shard-0-of-2.csv DESTINATION ${T}/failure_index)
  refused(failure_index "shard-1-of-2.json: /failures/0/index is \"[0-9]+\", its rows give [0-9]+" ${T}/failure_index)
endif()

# 10. Wide integers in the identity: N beyond an int, a shard index beyond 2^32.
string(REGEX REPLACE "\"scenarios\": ([0-9]+)," "\"scenarios\": 99999999999," j "${json0}")
attack(wide_n "${j}" "${csv0}")
refused(wide_n "shard-0-of-2.json: campaign.scenarios: 99999999999 is outside 1..2147483647" ${T}/wide_n)
string(REGEX REPLACE "(\"shard\": {[\n ]*\"index\": )0" "\\14294967296" j "${json0}")
attack(wide_k "${j}" "${csv0}")
refused(wide_k "shard-0-of-2.json: shard.index 4294967296 outside 0..1" ${T}/wide_k)

# 11. A row out of range (a path of 1e300 m), digest recomputed: the row is refused by column.
string(REGEX REPLACE "\n0,([0-9]+),([a-z_]+),([0-9.]*),[0-9.]+," "\n0,\\1,\\2,\\3,1e300," c "${csv0}")
with_digest_of("${c}" "${json0}" j)
attack(huge_row "${j}" "${c}")
refused(huge_row "shard-0-of-2.csv:2: column 5 \\(path_length\\): '1e300' is not a number" ${T}/huge_row)
