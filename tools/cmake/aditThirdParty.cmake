# SPDX-License-Identifier: BSD-3-Clause
# OctoMap 1.9.7 and OMPL 1.5.2 (Debian) describe themselves in variables (OCTOMAP_*, OMPL_*) whose
# paths belong to the machine they were found on. Each is wrapped once, after its find_package(),
# as an imported target: adit::3rd::octomap (private to adit::map) and adit::3rd::ompl (private to
# adit::global). Imported, the targets are named, not copied, in adit's exported link interface,
# so the installed package config includes this file too and rebuilds them from the consumer's
# own find_dependency() results; no path of the machine adit was built on is installed.
function(_adit_wrap_variables name prefix)  # adit::3rd::<name> from <prefix>_INCLUDE_DIRS, _LIBRARIES
  if(NOT TARGET adit::3rd::${name})
    add_library(adit::3rd::${name} INTERFACE IMPORTED)
    set_target_properties(adit::3rd::${name} PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${${prefix}_INCLUDE_DIRS}"
      INTERFACE_LINK_LIBRARIES "${${prefix}_LIBRARIES}")
  endif()
endfunction()
_adit_wrap_variables(octomap OCTOMAP)
_adit_wrap_variables(ompl OMPL)
