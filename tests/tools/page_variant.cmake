# SPDX-License-Identifier: BSD-3-Clause
# Makes a copy of a page with a script or an element added at the end of its body, to show that
# browser_page.cmake catches what it must and that the controls work:
# -DIN=<page> -DOUT=<page> -DKIND=throw   a script that throws after the player started
# -DIN=<page> -DOUT=<page> -DKIND=fetch   an image from the network (loopback, discard port), which
#                                         the page's Content-Security-Policy must block and record
# -DIN=<page> -DOUT=<page> -DKIND=drive   a script that works the controls like a user (pause,
#                                         slider, arrow key, End, play again from the start, speed
#                                         10x) and writes "ok" or what failed into data-drive
# -DIN=<page> -DOUT=<page> -DKIND=click   a script that clicks every timeline mark and writes "ok"
#                                         or what failed into data-click
file(READ "${IN}" html)
if(KIND STREQUAL "throw")
  set(extra "<script>null.boom();</script>")
elseif(KIND STREQUAL "fetch")
  set(extra "<img alt=\"\" src=\"http://127.0.0.1:9/blocked.png\">")
elseif(KIND STREQUAL "drive")
  file(READ "${CMAKE_CURRENT_LIST_DIR}/page_drive.js" script)
  set(extra "<script>${script}</script>")
elseif(KIND STREQUAL "click")
  file(READ "${CMAKE_CURRENT_LIST_DIR}/page_click.js" script)
  set(extra "<script>${script}</script>")
else()
  message(FATAL_ERROR "KIND must be throw, fetch, drive or click")
endif()
string(REPLACE "</body>" "${extra}</body>" html "${html}")
file(WRITE "${OUT}" "${html}")
