# install(EXPORT) with a package config, so another project can find_package(polyrad).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS polyrad polyrad_warnings EXPORT polyradTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS polyrad_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# Where io/image_codec.cpp looks for it: ../lib/polyrad from the executable, or the prefix's.
install(TARGETS polyrad_image_codec LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/polyrad)
# Not the relighting service's headers: its library (src/serve) is not installed.
install(DIRECTORY include/polyrad DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} PATTERN serve EXCLUDE)
install(EXPORT polyradTargets NAMESPACE polyrad::
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/polyrad)
configure_package_config_file(cmake/polyradConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/polyradConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/polyrad)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/polyradConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/polyradConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/polyradConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/polyrad)
