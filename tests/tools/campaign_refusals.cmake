# SPDX-License-Identifier: BSD-3-Clause
# `adit campaign merge` refuses (exit 2, naming the files) missing, duplicate and foreign shards,
# and writes no report then; `adit simulate --replay` refuses a map changed since the campaign
# and an index outside it, and names a relative map path it cannot find from here (the map then
# comes with --map). Uses the shards of campaign_shards.cmake (fixture campaign_shards).
# Args: ADIT, OUT, SEED.
set(C ${OUT}/campaign)
set(F ${C}/refusals)
file(REMOVE_RECURSE ${F})
file(MAKE_DIRECTORY ${F}/seed ${F}/map)

function(refused what expect)
  execute_process(COMMAND ${ADIT} campaign merge ${ARGN} --out ${F}/report.json
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "${what}: expected exit 2, got ${rc}:\n${err}")
  endif()
  if(NOT err MATCHES "${expect}")
    message(FATAL_ERROR "${what}: stderr does not match '${expect}':\n${err}")
  endif()
  if(EXISTS ${F}/report.json)
    message(FATAL_ERROR "${what}: a report was written")
  endif()
  message(STATUS "${what}: refused:\n${err}")
endfunction()

refused(missing "missing shards of the campaign of [^\n]*: shard-2-of-4.json"
        ${C}/m4/shard-0-of-4.json ${C}/m4/shard-1-of-4.json ${C}/m4/shard-3-of-4.json)
refused(duplicate "rerun/shard-1-of-4.json: duplicate of shard 1 \\(also [^\n]*m4/shard-1-of-4.json\\)"
        ${C}/m4 ${C}/rerun)
refused(other_shard_count "m4/shard-1-of-4.json: a shard of another campaign than [^\n]*m2/shard-0-of-2.json: shards \\(4 vs 2\\)"
        ${C}/m2/shard-0-of-2.json ${C}/m4/shard-1-of-4.json)

# Shard 1 of 2 as another seed or another map would have written it.
file(READ ${C}/m2/shard-1-of-2.json shard)
string(REPLACE "\"seed\": ${SEED}," "\"seed\": 99${SEED}," other_seed "${shard}")
file(WRITE ${F}/seed/shard-1-of-2.json "${other_seed}")
refused(other_seed "seed/shard-1-of-2.json: a shard of another campaign than [^\n]*: seed \\(99${SEED} vs ${SEED}\\)"
        ${C}/m2/shard-0-of-2.json ${F}/seed)
string(REGEX REPLACE "\"map_hash\": \"fnv1a64:[0-9a-f]+\"" "\"map_hash\": \"fnv1a64:0123456789abcdef\"" other_map "${shard}")
file(WRITE ${F}/map/shard-1-of-2.json "${other_map}")
refused(other_map "map/shard-1-of-2.json: a shard of another campaign than [^\n]*: map content"
        ${C}/m2/shard-0-of-2.json ${F}/map/shard-1-of-2.json)
refused(not_a_shard "m1_report.json: no shard.index.*shard-0-of-1.csv: not JSON"
        ${C}/m1_report.json ${C}/m1/shard-0-of-1.csv ${C}/m2)

# Replay: the recorded map hash no longer matches the map; an index beyond N.
function(replay_refused spec expect)
  execute_process(COMMAND ${ADIT} simulate -q --replay ${spec} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "${expect}")
    message(FATAL_ERROR "--replay ${spec}: expected exit 2 and '${expect}', got ${rc}:\n${err}")
  endif()
endfunction()
replay_refused(${F}/map/shard-1-of-2.json:1 "campaign_loop.yaml: the map changed since the campaign \\(fnv1a64:[0-9a-f]+, recorded fnv1a64:0123456789abcdef in [^)]*map/shard-1-of-2.json\\)")
replay_refused(${C}/m2:8 "--replay [^ ]*m2:8: the campaign has scenarios 0..7")

# A campaign run elsewhere with a relative map path: refused with where it looked, then replayed
# with --map (the same content: the hash still matches).
file(MAKE_DIRECTORY ${F}/relative)
string(REGEX REPLACE "\"map\": \"[^\"]*campaign_loop.yaml\"" "\"map\": \"maps/campaign_loop.yaml\"" relative_map "${shard}")
string(REGEX MATCH "\"map\": \"[^\"]*campaign_loop.yaml\"" recorded_map "${shard}")
string(REGEX REPLACE "\"map\": \"([^\"]*)\"" "\\1" recorded_map "${recorded_map}")
file(WRITE ${F}/relative/shard-1-of-2.json "${relative_map}")
execute_process(COMMAND ${ADIT} simulate -q --replay ${F}/relative:1 WORKING_DIRECTORY ${F}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "maps/campaign_loop.yaml: the campaign's map \\(recorded in [^)]*relative/shard-1-of-2.json relative to where `adit campaign run` ran\\) is not found from [^:]*: replay from that directory, or give the map with --map FILE")
  message(FATAL_ERROR "--replay with a relative map from elsewhere: expected exit 2 and the map's message, got ${rc}:\n${err}")
endif()
execute_process(COMMAND ${ADIT} simulate -q --replay ${F}/relative:1 --map ${recorded_map} --out ${F}/relative/run.json
                WORKING_DIRECTORY ${F} RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT EXISTS ${F}/relative/run.json OR rc GREATER 1)
  message(FATAL_ERROR "--replay --map ${recorded_map}: expected the run, got ${rc}:\n${err}")
endif()
message(STATUS "replay of a relative map: refused from elsewhere, run with --map")
