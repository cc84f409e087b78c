# DART 6 (Debian's libdart-dev) as a peer: the `dart` solver (solvers/dart.hpp), registered
# when DART is found.
find_package(DART 6 CONFIG QUIET COMPONENTS dart)
if(DART_FOUND AND EXISTS ${CMAKE_SOURCE_DIR}/solvers/dart_bridge.cpp)
  # The bridge includes DART's headers. It is compiled as Debian compiled libdart: generic
  # x86-64 and Eigen's default alignment, so without -march=native and without minv's Eigen
  # definitions (a -march=native translation unit that builds a Skeleton aborts inside DART).
  # Only plain numbers cross between it and minv (solvers/plain_tree.hpp).
  # It is a module of its own, which solvers/dart.cpp loads with dlopen(RTLD_LOCAL |
  # RTLD_DEEPBIND), and minv does not link libdart: linked into minv, libdart's own calls to
  # out-of-line Eigen functions (aligned_malloc, PlainObjectBase::resize, the GEMV kernels)
  # bind at run time to the -march=native, 64-byte copies that minv's libraries export.
  add_library(minv_dart_bridge MODULE solvers/dart_bridge.cpp)
  target_include_directories(minv_dart_bridge PRIVATE ${CMAKE_SOURCE_DIR})
  target_link_libraries(minv_dart_bridge PRIVATE dart)
  target_compile_options(minv_dart_bridge PRIVATE -fvisibility=hidden)
  add_dependencies(minv_solvers minv_dart_bridge)
  target_link_libraries(minv_solvers PRIVATE ${CMAKE_DL_LIBS})
  # dart.cpp looks for the module next to libminv_solvers (build tree and install), then here.
  target_compile_definitions(minv_solvers PRIVATE MINV_HAVE_DART=1
                             MINV_DART_BRIDGE_NAME="$<TARGET_FILE_NAME:minv_dart_bridge>"
                             MINV_DART_BRIDGE_BUILD_PATH="$<TARGET_FILE:minv_dart_bridge>")
  list(APPEND MINV_PEER_TARGETS minv_dart_bridge)
  message(STATUS "minv: DART ${DART_VERSION} found: the `dart` solver is registered")
else()
  message(STATUS "minv: DART not found: no `dart` solver (scripts/setup installs libdart-dev)")
endif()
