# Lets scripts/fuzz build the fuzz targets while the top-level CMakeLists.txt does not yet
# include tests/fuzz: passed as -DCMAKE_PROJECT_INCLUDE=…/standalone.cmake, it defers an
# add_subdirectory(tests/fuzz) to the end of the top-level file. Contract: does nothing when
# the top-level file already names tests/fuzz itself, so the directory is never added twice.
file(READ ${CMAKE_SOURCE_DIR}/CMakeLists.txt minv_fuzz_top)
string(FIND "${minv_fuzz_top}" "tests/fuzz" minv_fuzz_at)
if(minv_fuzz_at EQUAL -1)
  cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL add_subdirectory
                 ${CMAKE_CURRENT_LIST_DIR} ${CMAKE_BINARY_DIR}/tests/fuzz)
endif()
