# The layering check (run at build time by the minv_layers target, and by hand with
#   cmake -DSOURCE_DIR=$PWD -P cmake/check_layers.cmake):
# every #include "<folder>/…" of a file in a layer must point to the same layer or one below.
#   0 core/  1 generators/  2 solvers/  3 sim/  4 experiments/lib/  5 experiments/ (programs)
# An include that points upwards fails the build with the file, the line and the two layers.
set(layers core generators solvers sim experiments/lib experiments)
function(layer_of path out)
  set(rank -1)
  set(i 0)
  foreach(l ${layers})
    string(LENGTH "${l}/" len)
    string(SUBSTRING "${path}" 0 ${len} head)
    if(head STREQUAL "${l}/")
      set(rank ${i})  # later (longer) matches win: experiments/lib/ over experiments/
      if(l STREQUAL "experiments")
        string(FIND "${path}" "experiments/lib/" lib)
        if(lib EQUAL 0)
          set(rank 4)
        endif()
      endif()
    endif()
    math(EXPR i "${i} + 1")
  endforeach()
  set(${out} ${rank} PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE files RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/core/*.[ch]pp ${SOURCE_DIR}/generators/*.[ch]pp ${SOURCE_DIR}/solvers/*.[ch]pp
     ${SOURCE_DIR}/sim/*.[ch]pp ${SOURCE_DIR}/experiments/*.[ch]pp)
set(errors "")
foreach(f ${files})
  layer_of(${f} from)
  file(STRINGS ${SOURCE_DIR}/${f} lines REGEX "^#include \"")
  foreach(line ${lines})
    string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" target "${line}")
    layer_of(${target} to)
    if(to GREATER from)
      list(GET layers ${from} a)
      list(GET layers ${to} b)
      string(APPEND errors "  ${f}: #include \"${target}\" points from ${a}/ up to ${b}/\n")
    endif()
  endforeach()
endforeach()
if(errors)
  message(FATAL_ERROR "layering: includes against the layer order "
                      "(core → generators → solvers → sim → experiments/lib → experiments):\n${errors}")
endif()
