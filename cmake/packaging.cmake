# Install rules and the Debian package (docs/packaging.md).
#
#   cmake --build build --target package      # build/clm-servo_<version>_<arch>.deb
#   apt-get install ./build/clm-servo_*.deb
#
# With the package's prefix /usr: the binaries in /usr/bin, the unit in
# /lib/systemd/system (merged /usr: /usr/lib/systemd/system), the default
# configuration (the embedded simulated motor) with its programs in
# /etc/clm-servo, the real-axis templates and the report plotter in
# /usr/share/clm-servo, the documentation in /usr/share/doc/clm-servo. The
# state directory /var/lib/clm-servo is the unit's StateDirectory=.
include(GNUInstallDirs)

set(CLM_SYSTEMD_UNIT_DIR "lib/systemd/system" CACHE STRING
    "where the systemd unit is installed, relative to the prefix or absolute")
# /etc whatever the prefix, as Debian's own packages do for /usr.
set(CLM_CONFIG_DIR "/etc/clm-servo" CACHE STRING "where the default configuration is installed")

install(TARGETS clm clm-servod RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_SOURCE_DIR}/systemd/clm-servod.service DESTINATION ${CLM_SYSTEMD_UNIT_DIR})
install(FILES ${PROJECT_SOURCE_DIR}/config/servod.yaml ${PROJECT_SOURCE_DIR}/config/motor-sim.yaml
        DESTINATION ${CLM_CONFIG_DIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/programs DESTINATION ${CLM_CONFIG_DIR} FILES_MATCHING PATTERN "*.yaml")
install(FILES ${PROJECT_SOURCE_DIR}/config/servod-real.yaml ${PROJECT_SOURCE_DIR}/config/motor-real.yaml
        DESTINATION ${CMAKE_INSTALL_DATADIR}/clm-servo/templates)
install(PROGRAMS ${PROJECT_SOURCE_DIR}/tools/commission/plot_report.py DESTINATION ${CMAKE_INSTALL_DATADIR}/clm-servo)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/clm-servo FILES_MATCHING PATTERN "*.md")
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/drivers/can/clm-servo.dbc
              ${PROJECT_SOURCE_DIR}/drivers/can/clm-servo-phase-current.dbc
        DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/clm-servo)

# The build tree mirrors share/clm-servo beside bin/, so that clm finds the
# plotter the same way in both (relative to its own executable).
configure_file(${PROJECT_SOURCE_DIR}/tools/commission/plot_report.py
               ${CMAKE_BINARY_DIR}/${CMAKE_INSTALL_DATADIR}/clm-servo/plot_report.py COPYONLY)

set(CPACK_PACKAGE_NAME clm-servo)
set(CPACK_PACKAGE_VENDOR "clm-servo")
set(CPACK_PACKAGE_CONTACT "clm-servo maintainers <clm-servo@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "real-time servo daemon and commissioning tools for coreless linear motors")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
# Library dependencies from the binaries (dpkg-shlibdeps), plus what the
# tools run: python3 with numpy and matplotlib for the plots.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3, python3-numpy, python3-matplotlib")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "can-utils, liblcm-bin")
# Everything under /etc is the administrator's once installed.
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
# postinst makes the group clm-operators and the operators' key
# /etc/clm-servo/command.key (root:clm-operators, 0640) unless it exists;
# postrm removes the key on purge.
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${PROJECT_SOURCE_DIR}/cmake/debian/postinst;${PROJECT_SOURCE_DIR}/cmake/debian/postrm")
include(CPack)
