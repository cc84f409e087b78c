# Bullet 3 (Debian's libbullet-dev) as a peer: the `bullet` solver (solvers/bullet.hpp), the
# double-precision build (bullet-float64.pc: -DBT_USE_DOUBLE_PRECISION, libraries *-float64),
# registered when it is found.
find_package(PkgConfig QUIET)
if(PkgConfig_FOUND)
  pkg_check_modules(BULLET64 QUIET IMPORTED_TARGET bullet-float64)
endif()
if(BULLET64_FOUND AND EXISTS ${CMAKE_SOURCE_DIR}/solvers/bullet_bridge.cpp)
  # BT_USE_DOUBLE_PRECISION changes btScalar and every Bullet type: it is confined to the
  # bridge, compiled with Bullet's flags (generic x86-64); only plain numbers cross between it
  # and minv (solvers/plain_tree.hpp).
  add_library(minv_bullet_bridge OBJECT solvers/bullet_bridge.cpp)
  target_include_directories(minv_bullet_bridge PRIVATE ${CMAKE_SOURCE_DIR})
  target_link_libraries(minv_bullet_bridge PRIVATE PkgConfig::BULLET64)
  target_sources(minv_solvers PRIVATE $<TARGET_OBJECTS:minv_bullet_bridge>)
  target_link_libraries(minv_solvers PRIVATE PkgConfig::BULLET64)
  target_compile_definitions(minv_solvers PRIVATE MINV_HAVE_BULLET=1)
  message(STATUS "minv: Bullet ${BULLET64_VERSION} (double precision) found: the `bullet` solver is registered")
else()
  message(STATUS "minv: Bullet (bullet-float64) not found: no `bullet` solver (scripts/setup installs libbullet-dev)")
endif()
