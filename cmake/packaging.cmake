# Install rules and the Debian package (docs/packaging.md).
#
#   cmake --build build --target package      # build/clm-servo_<version>_<arch>.deb
#   apt-get install ./build/clm-servo_*.deb
#
# With the package's prefix /usr: the binaries in /usr/bin, the units in
# /lib/systemd/system (merged /usr: /usr/lib/systemd/system), the default
# configuration (the embedded simulated motor) with its programs in
# /etc/clm-servo (conffiles), the real-axis templates, the report plotter and
# the LCM types jar for lcm-spy in /usr/share/clm-servo, man pages, the
# documentation in /usr/share/doc/clm-servo, and /var/lib/clm-servo for
# commissioning output (root:clm-operators, set by postinst).
include(GNUInstallDirs)

set(CLM_SYSTEMD_UNIT_DIR "lib/systemd/system" CACHE STRING
    "where the systemd unit is installed, relative to the prefix or absolute")
# /etc whatever the prefix, as Debian's own packages do for /usr.
set(CLM_CONFIG_DIR "/etc/clm-servo" CACHE STRING "where the default configuration is installed")

set(CLM_STATE_DIR "/var/lib/clm-servo" CACHE STRING "where commissioning output goes on an installed system")

install(TARGETS clm clm-servod RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_SOURCE_DIR}/systemd/clm-servod.service ${PROJECT_SOURCE_DIR}/systemd/clm-vcan0.service
        DESTINATION ${CLM_SYSTEMD_UNIT_DIR})

# The packaged configuration is config/servod.yaml (the build tree's embedded
# default, whose file directories are its own) with the state directory
# allowed too, so that commissioning output there loads.
file(READ ${PROJECT_SOURCE_DIR}/config/servod.yaml clm_packaged_config)
if(clm_packaged_config MATCHES "\ncommands:")
  message(FATAL_ERROR "config/servod.yaml has a commands: section: cmake/packaging.cmake must add "
                      "${CLM_STATE_DIR} to its file_directories instead of appending the section")
endif()
string(APPEND clm_packaged_config
       "commands:\n"
       "  # The package's directories: this one, and ${CLM_STATE_DIR} for commissioning output\n"
       "  # (root:clm-operators, docs/packaging.md).\n"
       "  file_directories: [${CLM_CONFIG_DIR}, ${CLM_STATE_DIR}]\n")
file(WRITE ${CMAKE_BINARY_DIR}/package/servod.yaml "${clm_packaged_config}")
install(FILES ${CMAKE_BINARY_DIR}/package/servod.yaml ${PROJECT_SOURCE_DIR}/config/motor-sim.yaml
        DESTINATION ${CLM_CONFIG_DIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/programs DESTINATION ${CLM_CONFIG_DIR} FILES_MATCHING PATTERN "*.yaml")
install(DIRECTORY DESTINATION ${CLM_STATE_DIR})
# Every file under /etc is a conffile: an upgrade keeps what the administrator
# (or `clm ctl save`, `clm commission --save`) changed, remove keeps it, purge
# removes it.
file(GLOB clm_programs RELATIVE ${PROJECT_SOURCE_DIR}/config ${PROJECT_SOURCE_DIR}/config/programs/*.yaml)
set(clm_conffiles "${CLM_CONFIG_DIR}/servod.yaml\n${CLM_CONFIG_DIR}/motor-sim.yaml\n")
foreach(program IN LISTS clm_programs)
  string(APPEND clm_conffiles "${CLM_CONFIG_DIR}/${program}\n")
endforeach()
file(WRITE ${CMAKE_BINARY_DIR}/package/conffiles "${clm_conffiles}")

# Man pages from the programs' --help (help2man), when help2man is there;
# .ci/install-deps.sh installs it, and the package test requires them.
find_program(CLM_HELP2MAN help2man DOC "help2man (Debian package help2man), for the man pages")
if(CLM_HELP2MAN)
  set(clm_man_pages)
  foreach(program clm clm-servod)
    set(page ${CMAKE_BINARY_DIR}/package/man/${program}.1)
    add_custom_command(OUTPUT ${page}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_BINARY_DIR}/package/man
      COMMAND ${CLM_HELP2MAN} --no-info --no-discard-stderr --section 1 --output ${page} $<TARGET_FILE:${program}>
      DEPENDS ${program}
      COMMENT "help2man: ${program}.1")
    list(APPEND clm_man_pages ${page})
  endforeach()
  add_custom_target(clm_man_pages ALL DEPENDS ${clm_man_pages})
  install(FILES ${clm_man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
endif()

# The LCM types for lcm-spy, and a launcher that finds them (lcmtypes/).
if(TARGET clm_lcmtypes_jar)
  install(FILES ${CMAKE_BINARY_DIR}/lcmtypes/clm_lcmtypes.jar DESTINATION ${CMAKE_INSTALL_DATADIR}/clm-servo)
  install(PROGRAMS ${PROJECT_SOURCE_DIR}/tools/clm-spy DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(FILES ${PROJECT_SOURCE_DIR}/config/servod-real.yaml ${PROJECT_SOURCE_DIR}/config/motor-real.yaml
        DESTINATION ${CMAKE_INSTALL_DATADIR}/clm-servo/templates)
# The plotters clm runs (tools/cli/share_script.hpp).
set(CLM_SHARE_SCRIPTS ${PROJECT_SOURCE_DIR}/tools/commission/plot_report.py ${PROJECT_SOURCE_DIR}/tools/scope/plot_capture.py)
install(PROGRAMS ${CLM_SHARE_SCRIPTS} DESTINATION ${CMAKE_INSTALL_DATADIR}/clm-servo)
# The documentation as the source tree lays it out (README.md beside docs/,
# its images in docs/images), so that the links between them hold.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/clm-servo
        FILES_MATCHING PATTERN "*.md" PATTERN "*.png")
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/drivers/can/clm-servo.dbc
              ${PROJECT_SOURCE_DIR}/drivers/can/clm-servo-phase-current.dbc
        DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/clm-servo)

# The build tree mirrors share/clm-servo beside bin/, so that clm finds the
# plotters the same way in both (relative to its own executable).
foreach(script ${CLM_SHARE_SCRIPTS})
  get_filename_component(script_name ${script} NAME)
  configure_file(${script} ${CMAKE_BINARY_DIR}/${CMAKE_INSTALL_DATADIR}/clm-servo/${script_name} COPYONLY)
endforeach()

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
# lcm-spy (clm-spy): Java, LCM's jar and the chart library it draws with.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "can-utils, liblcm-bin, liblcm-java, libjchart2d-java, default-jre")
# Everything under /etc is the administrator's once installed.
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
# postinst makes the group clm-operators, the operators' key
# /etc/clm-servo/command.key (root:clm-operators, 0640) unless it exists, and
# gives /var/lib/clm-servo to the group; postrm removes the key on purge.
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    "${PROJECT_SOURCE_DIR}/cmake/debian/postinst;${PROJECT_SOURCE_DIR}/cmake/debian/postrm;${CMAKE_BINARY_DIR}/package/conffiles")
include(CPack)
