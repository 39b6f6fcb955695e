# CPack: `cpack --config build/CPackConfig.cmake -G DEB` (or `cmake --build build --target package`) builds
# cpgmatch_<version>_<arch>.deb. Its dependencies are what the executables link (dpkg-shlibdeps) plus the
# programs they run: gnuplot for the figures, fastdds-tools for the discovery server.
set(CPACK_PACKAGE_NAME cpgmatch)
set(CPACK_PACKAGE_VENDOR "cpgmatch")
set(CPACK_PACKAGE_CONTACT "cpgmatch maintainers <cpgmatch@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "plastic matching of a legged robot's CPG to its natural dynamics, over DDS")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "fastdds-tools, libjs-chart.js")  # libjs-chart.js: the dashboard serves it
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "gnuplot-nox | gnuplot")
include(CPack)
