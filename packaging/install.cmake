# Installation (`cmake --install`, FHS places under the prefix) and the Debian package (CPack):
# the product binary, the systemd unit, the sysusers.d and tmpfiles.d entries, the docs and the
# examples. Tests and benchmarks have no install rules: never installed. docs/service.md.
include(GNUInstallDirs)

install(TARGETS gaugeloop RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# Under <prefix>/lib, not CMAKE_INSTALL_LIBDIR (lib/x86_64-linux-gnu for /usr on Debian): where
# systemd looks for them, /usr/local/lib/... for /usr/local.
install(FILES ${PROJECT_SOURCE_DIR}/packaging/sysusers.conf DESTINATION lib/sysusers.d RENAME gaugeloop.conf)
install(FILES ${PROJECT_SOURCE_DIR}/packaging/tmpfiles.conf DESTINATION lib/tmpfiles.d RENAME gaugeloop.conf)

# The docs as in the source tree, so their links hold: README.md, docs/*.md, examples/ beside.
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
set(GAUGELOOP_DOCS
  PERFORMANCE.md acquisition.md aqdef.md architecture.md building.md compensation.md gauge.md gears.md http_api.md
  crankpins.md nc_output.md parts.md plant.md reports.md service.md simulator.md spc_and_shafts.md storage.md
  variable_speed.md virtual_grinder.md)
list(TRANSFORM GAUGELOOP_DOCS PREPEND ${PROJECT_SOURCE_DIR}/docs/)
install(FILES ${GAUGELOOP_DOCS} DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)
install(FILES ${PROJECT_SOURCE_DIR}/docs/img/cam_report.png ${PROJECT_SOURCE_DIR}/docs/img/crankpin_frames.svg
              ${PROJECT_SOURCE_DIR}/docs/img/web_run_page.png ${PROJECT_SOURCE_DIR}/docs/img/new_program_preview.png
              ${PROJECT_SOURCE_DIR}/docs/img/gear_axes.svg
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs/img)
# The service's example config and what its relative paths name (gauge config, parts and
# their lift tables, the NC template), so `serve --check` passes on it as installed. Listed,
# not the folder: a run from the source tree leaves databases and NC files in it.
set(GAUGELOOP_EXAMPLES
  exhaust_roller.csv exhaust_roller.toml intake_flat.csv intake_flat.toml intake_flat_half_degree.csv
  intake_flat_half_degree.toml)
list(APPEND GAUGELOOP_EXAMPLES camshaft.toml)  # names intake_flat.toml and exhaust_roller.toml
list(APPEND GAUGELOOP_EXAMPLES crankpin_cx.toml crankpin_cxy.toml)  # the sample crankpin, C-X and C-X-Y
list(APPEND GAUGELOOP_EXAMPLES gear_71.toml gear_71_axis_errors.csv)  # the generating grinder's test gear
list(APPEND GAUGELOOP_EXAMPLES intake_flat_layer.toml)  # the intake lobe with its correction as a layer
list(TRANSFORM GAUGELOOP_EXAMPLES PREPEND ${PROJECT_SOURCE_DIR}/examples/)
install(FILES ${GAUGELOOP_EXAMPLES} DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)
install(FILES ${PROJECT_SOURCE_DIR}/examples/gauges/simulator.toml ${PROJECT_SOURCE_DIR}/examples/gauges/other_amplifier.toml
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/gauges)
install(FILES ${PROJECT_SOURCE_DIR}/examples/service/gaugeloop.toml DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/service)
install(FILES ${PROJECT_SOURCE_DIR}/examples/sinumerik/cam_main.mpf ${PROJECT_SOURCE_DIR}/examples/sinumerik/cam_table.spf
              ${PROJECT_SOURCE_DIR}/examples/sinumerik/cam_main_speed.mpf ${PROJECT_SOURCE_DIR}/examples/sinumerik/cam_speed.spf
              ${PROJECT_SOURCE_DIR}/examples/sinumerik/pin_main.mpf ${PROJECT_SOURCE_DIR}/examples/sinumerik/pin_main_cx.mpf
              ${PROJECT_SOURCE_DIR}/examples/sinumerik/pin_y_table.spf ${PROJECT_SOURCE_DIR}/examples/sinumerik/gear_main.mpf
              ${PROJECT_SOURCE_DIR}/examples/sinumerik/cam_main_layer.mpf
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/sinumerik)

# The unit names the binary by its installed path. The prefix is known for certain only when
# installing (`cmake --install --prefix`, CPack's /usr), so the unit is written then. The
# unit goes to <prefix>/lib/systemd/system, for the prefix /usr to /lib/systemd/system as
# Debian 12's own packages do; GAUGELOOP_SYSTEMD_UNIT_DIR sets another.
set(GAUGELOOP_SYSTEMD_UNIT_DIR "" CACHE PATH
    "Where the systemd unit is installed; empty: <prefix>/lib/systemd/system, /lib/systemd/system for /usr")
install(CODE "
  set(GAUGELOOP_BINDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  set(GAUGELOOP_DOCDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DOCDIR}\")
  set(unit_dir \"${GAUGELOOP_SYSTEMD_UNIT_DIR}\")
  if(NOT unit_dir)
    if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
      set(unit_dir /lib/systemd/system)
    else()
      set(unit_dir \"\${CMAKE_INSTALL_PREFIX}/lib/systemd/system\")
    endif()
  endif()
  configure_file(\"${PROJECT_SOURCE_DIR}/packaging/gaugeloop.service.in\"
                 \"${PROJECT_BINARY_DIR}/packaging/install/gaugeloop.service\" @ONLY)
  file(INSTALL \"${PROJECT_BINARY_DIR}/packaging/install/gaugeloop.service\" DESTINATION \"\${unit_dir}\"
       PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)
")
# The same unit for the configured prefix, for the tests (tests/packaging) to check.
set(GAUGELOOP_BINDIR ${CMAKE_INSTALL_FULL_BINDIR})
set(GAUGELOOP_DOCDIR ${CMAKE_INSTALL_FULL_DOCDIR})
configure_file(${PROJECT_SOURCE_DIR}/packaging/gaugeloop.service.in ${PROJECT_BINARY_DIR}/packaging/gaugeloop.service
               @ONLY)

# The Debian package: `make package` (cpack in the Release build directory).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME gaugeloop)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "closed-loop cam grinding: in-process gauge to NC curve table")
set(CPACK_PACKAGE_DESCRIPTION
    "gaugeloop reads an LVDT gauge over Modbus beside a CNC camshaft grinder, analyses the lobe, \
compensates and writes the Sinumerik curve table the control grinds the next part with. Runs are \
kept in SQLite. The service (systemd unit gaugeloop.service) measures on a PLC's Modbus handshake \
or over HTTP.")
set(GAUGELOOP_PACKAGE_MAINTAINER "gaugeloop maintainers <root@localhost>" CACHE STRING
    "Maintainer field of the Debian package: who builds it for the plant")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${GAUGELOOP_PACKAGE_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
# Installed with DESTDIR, as a packager's `make install` is: the prefix /usr seen as it will be
# on the grinder's PC (the unit names /usr/bin/gaugeloop), and the unit's absolute
# /lib/systemd/system goes into the package, not onto the build machine.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
# The shared libraries' packages from dpkg-shlibdeps; what the maintainer scripts call besides.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, init-system-helpers")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/postinst ${PROJECT_SOURCE_DIR}/packaging/prerm ${PROJECT_SOURCE_DIR}/packaging/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
