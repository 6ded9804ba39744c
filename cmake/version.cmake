# `cmake -DSOURCE_DIR=... -DVERSION=... -DOUT=... -P version.cmake`: writes OUT, a header with the
# version and the commit the source tree is at (git describe: "-dirty" where files differ from it),
# and only when that text changes, so a build at the same commit recompiles nothing.
execute_process(COMMAND git -C "${SOURCE_DIR}" describe --always --dirty --abbrev=12
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR commit STREQUAL "")
  set(commit "unknown (not built from a git clone)")
endif()
set(text "#pragma once\n#define ANISO_VERSION \"${VERSION}\"\n#define ANISO_COMMIT \"${commit}\"\n")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
  if(old STREQUAL text)
    return()
  endif()
endif()
file(WRITE "${OUT}" "${text}")
