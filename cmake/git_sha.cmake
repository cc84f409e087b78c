# Writes OUT = `#define MINV_GIT_SHA "<sha>"` for the source tree SRC at build time (run by the
# minv_git_sha target on every build), so a result file names the commit its binary was built
# from, not the one CMake was configured at. "-dirty" marks sources that differ from the commit,
# new files included (results/ and paper/ aside: they are outputs). The file is rewritten only
# when the text changes, so only provenance.cpp recompiles, and only after a new commit.
execute_process(COMMAND git rev-parse --short=12 HEAD WORKING_DIRECTORY ${SRC}
                OUTPUT_VARIABLE sha OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT sha)
  set(sha "unknown")
else()
  # Modified, staged or new (untracked, not ignored) files outside results/ and paper/.
  execute_process(COMMAND git status --porcelain -- . ":(exclude)results" ":(exclude)paper"
                  WORKING_DIRECTORY ${SRC} OUTPUT_VARIABLE changes ERROR_QUIET)
  if(NOT changes STREQUAL "")
    set(sha "${sha}-dirty")
  endif()
endif()
set(text "#define MINV_GIT_SHA \"${sha}\"\n")
set(old "")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${OUT} "${text}")
endif()
