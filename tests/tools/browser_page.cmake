# SPDX-License-Identifier: BSD-3-Clause
# Opens an animated page (adit simulate --html) in headless Chromium, offline, and checks that its
# script ran without error and advanced the animation; optionally takes a screenshot and checks it
# is not blank. Also the way to make the README's screenshot of a page:
#
#   cmake -DPAGE=run.html -DSCREENSHOT=docs/simulate.png [-DAT=42.5] -P tests/tools/browser_page.cmake
#
# -DPAGE=<html>            the page (required)
# -DSCREENSHOT=<png>       also write a screenshot there
# -DAT=<seconds>           also open the page at this run time (its #t=...), check that it is
#                          paused there, and take the screenshot there; default: the screenshot
#                          after BUDGET_MS of play from the start
# -DCHECK_PNG=<exe>        animation_page_demo, to refuse a blank screenshot
# -DCHECK_COLOUR=<RRGGBB>  with CHECK_PNG: a colour the screenshot must show (at least 20 pixels)
# -DCHROMIUM=<exe>         default /usr/bin/chromium
# -DBUDGET_MS=<ms>         virtual time the page runs for (default 4000)
# -DWINDOW=<w,h>           browser window size (default 1280,900)
# -DMIN_FRAME=<n>          the frame shown after BUDGET_MS must be at least this (default 1)
# -DEXPECT_ROOT=<regex>    the <html> element after BUDGET_MS must match this
# -DEXPECT_AT=<re>[@<re>]  with AT: the <html> element opened at AT must match each of these
#                          (separated by @, which a regex of attributes does not need)
# -DWORK=<dir>             scratch folder for the browser profiles (default: beside the page)
if(NOT DEFINED PAGE)
  message(FATAL_ERROR "usage: cmake -DPAGE=run.html [-DSCREENSHOT=out.png] -P browser_page.cmake")
endif()
get_filename_component(PAGE "${PAGE}" ABSOLUTE)
if(NOT EXISTS "${PAGE}")
  message(FATAL_ERROR "${PAGE}: no such page")
endif()
if(NOT DEFINED CHROMIUM)
  set(CHROMIUM /usr/bin/chromium)
endif()
if(NOT DEFINED BUDGET_MS)
  set(BUDGET_MS 4000)
endif()
if(NOT DEFINED WINDOW)
  set(WINDOW 1280,900)
endif()
if(NOT DEFINED WORK)
  get_filename_component(WORK "${PAGE}" DIRECTORY)
endif()

# Every run gets a fresh profile and no network service that could phone home; the page's own
# Content-Security-Policy blocks fetches, and any it tried would show up as an error below.
set(FLAGS --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --no-default-browser-check
          --disable-background-networking --disable-component-update --disable-sync
          --disable-default-apps --disable-extensions --mute-audio --hide-scrollbars
          --window-size=${WINDOW} --virtual-time-budget=${BUDGET_MS})

function(run_chromium profile url out_var)
  # One profile per page and run, so that tests of different pages can run in parallel.
  get_filename_component(page_name "${PAGE}" NAME_WE)
  set(dir "${WORK}/chromium-${page_name}-${profile}")
  file(REMOVE_RECURSE "${dir}")
  file(MAKE_DIRECTORY "${dir}")
  execute_process(COMMAND ${CHROMIUM} ${FLAGS} --user-data-dir=${dir} ${ARGN} ${url}
                  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 180)
  file(REMOVE_RECURSE "${dir}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "chromium exited with ${code}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

# 1. The DOM after BUDGET_MS of virtual time: the page records the frame it shows and any error.
string(TIMESTAMP started "%s")
run_chromium(dom "file://${PAGE}" dom --dump-dom)
string(REGEX MATCH "<html[^>]*>" root "${dom}")
message("root element after ${BUDGET_MS} ms: ${root}")
if(NOT root MATCHES "data-ready=\"1\"")
  message(FATAL_ERROR "the page's script did not finish starting up")
endif()
if(NOT root MATCHES "data-errors=\"0\"")
  string(REGEX MATCH "<pre id=\"errors\"[^<]*" errors "${dom}")
  message(FATAL_ERROR "the page recorded errors: ${errors}")
endif()
string(REGEX MATCH "data-frame=\"([0-9]+)\"" _ "${root}")
set(frame "${CMAKE_MATCH_1}")
if(NOT DEFINED MIN_FRAME)
  set(MIN_FRAME 1)
endif()
if(frame STREQUAL "" OR frame LESS MIN_FRAME)
  message(FATAL_ERROR "the animation did not advance to frame ${MIN_FRAME} (frame '${frame}')")
endif()
if(DEFINED EXPECT_ROOT AND NOT root MATCHES "${EXPECT_ROOT}")
  message(FATAL_ERROR "the root element does not match ${EXPECT_ROOT}")
endif()
string(REGEX MATCH "id=\"clock\">t = [0-9.]+ s" clock "${dom}")
if(clock STREQUAL "" OR clock MATCHES "t = 0\\.0 s")
  message(FATAL_ERROR "the clock did not move: '${clock}'")
endif()
message("advanced to frame ${frame}, ${clock}")

# 2. Opened at a time (#t=AT): paused there.
if(DEFINED AT)
  run_chromium(at "file://${PAGE}#t=${AT}" dom --dump-dom)
  string(REGEX MATCH "<html[^>]*>" root "${dom}")
  message("root element opened at ${AT} s: ${root}")
  string(REGEX MATCH "data-time=\"([0-9.]+)\"" _ "${root}")
  set(time "${CMAKE_MATCH_1}")
  if(NOT root MATCHES "data-errors=\"0\"" OR NOT root MATCHES "data-playing=\"0\"" OR time STREQUAL ""
     OR time GREATER AT)
    message(FATAL_ERROR "opened at ${AT} s, the page should show the last frame at or before it, paused")
  endif()
  string(REPLACE "@" ";" expect_at "${EXPECT_AT}")
  foreach(expected IN LISTS expect_at)
    if(NOT root MATCHES "${expected}")
      message(FATAL_ERROR "opened at ${AT} s, the root element does not match ${expected}")
    endif()
  endforeach()
endif()

# 3. The screenshot.
if(DEFINED SCREENSHOT)
  get_filename_component(SCREENSHOT "${SCREENSHOT}" ABSOLUTE)
  file(REMOVE "${SCREENSHOT}")
  set(url "file://${PAGE}")
  if(DEFINED AT)
    set(url "${url}#t=${AT}")
  endif()
  run_chromium(shot "${url}" shot --screenshot=${SCREENSHOT})
  if(NOT EXISTS "${SCREENSHOT}")
    message(FATAL_ERROR "chromium wrote no screenshot")
  endif()
  if(DEFINED CHECK_PNG)
    set(args check-png ${SCREENSHOT})
    if(DEFINED CHECK_COLOUR)
      list(APPEND args ${CHECK_COLOUR} 20)
    endif()
    execute_process(COMMAND ${CHECK_PNG} ${args} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
    message("${out}${err}")
    if(NOT code EQUAL 0)
      message(FATAL_ERROR "the screenshot failed its check")
    endif()
  endif()
  message("screenshot: ${SCREENSHOT}")
endif()
string(TIMESTAMP finished "%s")
math(EXPR seconds "${finished} - ${started}")
message("browser checks took ${seconds} s")
