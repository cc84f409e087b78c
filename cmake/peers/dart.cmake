# DART 6 (Debian's libdart-dev) as a peer: the `dart` solver (solvers/dart.hpp), registered
# when DART is found.
find_package(DART 6 CONFIG QUIET COMPONENTS dart)
if(DART_FOUND AND EXISTS ${CMAKE_SOURCE_DIR}/solvers/dart_bridge.cpp)
  # The bridge includes DART's headers. It is compiled as Debian compiled libdart: generic
  # x86-64 and Eigen's default alignment, so without -march=native and without minv's Eigen
  # definitions (a -march=native translation unit that builds a Skeleton aborts inside DART).
  # Only plain numbers cross between it and minv (solvers/plain_tree.hpp).
  add_library(minv_dart_bridge OBJECT solvers/dart_bridge.cpp)
  target_include_directories(minv_dart_bridge PRIVATE ${CMAKE_SOURCE_DIR})
  target_link_libraries(minv_dart_bridge PRIVATE dart)
  target_sources(minv_solvers PRIVATE $<TARGET_OBJECTS:minv_dart_bridge>)
  target_link_libraries(minv_solvers PRIVATE dart)
  target_compile_definitions(minv_solvers PRIVATE MINV_HAVE_DART=1)
  message(STATUS "minv: DART ${DART_VERSION} found: the `dart` solver is registered")
else()
  message(STATUS "minv: DART not found: no `dart` solver (scripts/setup installs libdart-dev)")
endif()
