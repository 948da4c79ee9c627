# SPDX-License-Identifier: BSD-3-Clause
# Makes a broken copy of a page, to show that browser_page.cmake catches what it must:
# -DIN=<page> -DOUT=<page> -DKIND=throw   a script that throws after the player started
# -DIN=<page> -DOUT=<page> -DKIND=fetch   an image from the network (loopback, discard port), which
#                                         the page's Content-Security-Policy must block and record
file(READ "${IN}" html)
if(KIND STREQUAL "throw")
  set(extra "<script>null.boom();</script>")
elseif(KIND STREQUAL "fetch")
  set(extra "<img alt=\"\" src=\"http://127.0.0.1:9/blocked.png\">")
else()
  message(FATAL_ERROR "KIND must be throw or fetch")
endif()
string(REPLACE "</body>" "${extra}</body>" html "${html}")
file(WRITE "${OUT}" "${html}")
