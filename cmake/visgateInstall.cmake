# Install and export (DESIGN section 1; STYLE "CMake"): `cmake --install BUILD --prefix P`
# puts the public headers in P/include/visgate, the static libraries in P/lib, and the
# package files (visgateConfig.cmake, its version file, the exported targets under the
# visgate:: namespace) in P/lib/cmake/visgate. Included by the root CMakeLists.txt after
# every target is defined.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# The public targets and every library they link. The internal libraries keep their names
# (visgate::vg_scene, ...): consumers link the public ones, which bring the rest.
set(_vg_public vg_api_scene vg_api_methods vg_api_oracle vg_api_repair visgate_plugin_abi)
set(_vg_internal visgate_warnings vg_geom vg_accel vg_scene vg_mesh vg_solver_core vg_raycast vg_iss vg_ssv vg_plucker
    vg_external vg_solver vg_oracle)

# The libraries' include folder is the source root (root-relative includes, STYLE); it
# is a build-only usage requirement: installed consumers see include/ only.
foreach(t ${_vg_internal})
  get_target_property(_type ${t} TYPE)
  get_target_property(_inc ${t} INTERFACE_INCLUDE_DIRECTORIES)
  if(_inc)
    set_property(TARGET ${t} PROPERTY INTERFACE_INCLUDE_DIRECTORIES "$<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>")
  endif()
endforeach()

install(TARGETS ${_vg_public} ${_vg_internal} EXPORT visgateTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES
  ${PROJECT_SOURCE_DIR}/include/visgate/visgate.h
  ${PROJECT_SOURCE_DIR}/include/visgate/plugin.h
  ${PROJECT_SOURCE_DIR}/include/visgate/testing.h
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/visgate)
install(EXPORT visgateTargets NAMESPACE visgate:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visgate)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/visgateConfig.cmake.in
  ${PROJECT_BINARY_DIR}/visgateConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visgate)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/visgateConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/visgateConfig.cmake ${PROJECT_BINARY_DIR}/visgateConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visgate)

# The CLI, so that an installed prefix can run `visgate check` on its own.
install(TARGETS visgate RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
