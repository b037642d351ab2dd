# Debian packages with CPack (docs/install.md, "Debian packages"): `cpack -G DEB` in a build
# directory (scripts/build-deb.sh makes a portable one) writes, from the install components of
# cmake/ShrmInstall.cmake, into /usr:
#   shrm         the command, its man pages and completion, the bundled maps, the docs
#   shrmd        the daemon, shrmd(8), the systemd units, the system user shrmd, /etc/shrmd
#   shrm-view    the viewer
#   libshrm-dev  static libraries, headers, the CMake package, pkg-config files, the proto file
#   shrm-imageio the module with OpenImageIO and OpenColorIO that the others load on demand
#                (core/io/image_module.h); each of them depends on it, at the same version
# Runtime dependencies come from what the binaries link (dpkg-shlibdeps); libshrm-dev depends on
# the -dev packages its CMake package finds. Each package carries
# /usr/share/doc/<package>/{copyright,changelog.Debian.gz} (deploy/debian/).

set(SHRM_DEB_RELEASE 1 CACHE STRING "Debian revision of the packages (VERSION-REVISION)")
# A placeholder address (RFC 2606): set your own for packages you distribute.
set(SHRM_DEB_MAINTAINER "shrm maintainers <maintainers@shrm.example.org>"
    CACHE STRING "Maintainer field of the Debian packages")

# The newest entry of deploy/debian/changelog must be this version (the test checks it too).
set(SHRM_DEB_CHANGELOG ${PROJECT_SOURCE_DIR}/deploy/debian/changelog)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${SHRM_DEB_CHANGELOG})
file(STRINGS ${SHRM_DEB_CHANGELOG} SHRM_DEB_CHANGELOG_TOP LIMIT_COUNT 1)
if(NOT SHRM_DEB_CHANGELOG_TOP MATCHES "^shrm \\(${PROJECT_VERSION}-${SHRM_DEB_RELEASE}\\) ")
  message(WARNING "deploy/debian/changelog: the newest entry is not "
                  "${PROJECT_VERSION}-${SHRM_DEB_RELEASE}: add one before packaging")
endif()
find_program(SHRM_GZIP gzip)
if(SHRM_GZIP)
  execute_process(COMMAND ${SHRM_GZIP} -9nc ${SHRM_DEB_CHANGELOG}
                  OUTPUT_FILE ${PROJECT_BINARY_DIR}/install/changelog.Debian.gz)
endif()

# One package per group; the deb_* components hold each package's copyright and changelog and
# are left out of a plain `cmake --install` (EXCLUDE_FROM_ALL).
set(SHRM_DEB_PACKAGES "")
set(SHRM_DEB_COMPONENT_GROUPS "")
# shrm_deb_package(group package component section [description lines...])
macro(shrm_deb_package group package component section)
  if(";${SHRM_INSTALLED_COMPONENTS};" MATCHES ";${component};")
    list(APPEND SHRM_DEB_PACKAGES ${group})
    string(TOUPPER ${group} _g)
    set(CPACK_DEBIAN_${_g}_PACKAGE_NAME ${package})
    set(CPACK_DEBIAN_${_g}_PACKAGE_SECTION ${section})
    string(REPLACE ";" "\n" CPACK_DEBIAN_${_g}_DESCRIPTION "${ARGN}")
    list(APPEND SHRM_DEB_COMPONENT_GROUPS ${component}:${group} deb_${group}:${group})
    install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/copyright
                  ${PROJECT_BINARY_DIR}/install/changelog.Debian.gz
            DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${package} COMPONENT deb_${group}
            EXCLUDE_FROM_ALL)
    # The packages are not uploaded to Debian: no ITP bug for the first entry to close.
    file(WRITE ${PROJECT_BINARY_DIR}/install/lintian/${package}
         "# Built outside Debian (cmake/ShrmPackaging.cmake): there is no ITP bug to close.\n"
         "${package}: initial-upload-closes-no-bugs\n")
    install(FILES ${PROJECT_BINARY_DIR}/install/lintian/${package}
            DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides COMPONENT deb_${group}
            EXCLUDE_FROM_ALL)
    list(APPEND CPACK_COMPONENTS_ALL ${component} deb_${group})
  endif()
endmacro()

set(SHRM_INSTALLED_COMPONENTS shrm dev imageio)
if(TARGET shrmd)
  list(APPEND SHRM_INSTALLED_COMPONENTS shrmd)
endif()
if(TARGET shrm-view)
  list(APPEND SHRM_INSTALLED_COMPONENTS shrm-view)
endif()
set(CPACK_COMPONENTS_ALL "")
shrm_deb_package(cli shrm shrm graphics
  "frequency-space prefiltering of HDR environment maps (SHRMs)"
  "shrm turns an HDR environment map and a BRDF into Spherical Harmonic"
  "Reflection Maps (Ramamoorthi and Hanrahan): the lighting and the BRDF are"
  "multiplied in spherical-harmonic space and synthesized into a cube map of"
  "low-order expansions of the view dependence, with orders chosen from an"
  "error tolerance."
  "."
  "This package holds the shrm command (prefilter, analyze, eval, reference,"
  "render, explicit, irradiance, info, batch; embedded or on an shrmd"
  "service), four CC0 HDR maps and the documentation.")
shrm_deb_package(daemon shrmd shrmd net
  "shrm prefilter service (gRPC)"
  "shrmd runs the prefilter, analysis, reference and irradiance jobs of shrm"
  "for clients over gRPC (shrm.v1.Shrm): uploads by SHA-256, caches of lighting"
  "and BRDF coefficients, admission control, health checking, Prometheus"
  "metrics, bearer tokens and TLS."
  "."
  "The package installs the systemd units shrmd.service (enabled) and"
  "shrmd@.service (replicas behind a load balancer), the system user shrmd and"
  "/etc/shrmd/shrmd.conf.")
shrm_deb_package(viewer shrm-view shrm-view graphics
  "OpenGL viewer of Spherical Harmonic Reflection Maps"
  "shrm-view renders SHRM files, or SHRMs it computes (embedded or on an shrmd"
  "service), on meshes: global and local SHRMs, SH/HSH lighting with normal"
  "mapping, H-basis irradiance, progressive ground truth and a difference view;"
  "headless screenshots.")
shrm_deb_package(imageio shrm-imageio imageio graphics
  "image formats and colour spaces for shrm (OpenImageIO, OpenColorIO)"
  "The module that shrm, shrmd, shrm-view and programs built with libshrm-dev"
  "load the first time they read a Radiance HDR, PFM, TIFF or PNG file, write a"
  "TIFF image or convert between colour spaces. OpenEXR files and the default"
  "colour space do not need it, so the programs start without loading"
  "OpenImageIO and OpenColorIO.")
shrm_deb_package(devel libshrm-dev dev libdevel
  "shrm libraries: SHRM prefiltering core, job layer and service client"
  "Static libraries (PIC) and headers of shrm: the core (spherical harmonics,"
  "transforms, image I/O, environment maps, BRDFs, SHRM synthesis), the job"
  "layer and the client library of the shrmd service, with the CMake package"
  "(find_package(shrm): shrm::core, shrm::jobs, shrm::client), pkg-config files"
  "(shrm-core, shrm-jobs, shrm-client) and the protocol (shrm/v1/shrm.proto).")

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME shrm)
set(CPACK_PACKAGE_VENDOR "shrm")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${SHRM_DEB_MAINTAINER}")
# (No CPACK_PACKAGE_DESCRIPTION_SUMMARY: CPackDeb would put it in front of every package's own.)
# Install as `cmake --install --prefix /usr` into a staging DESTDIR, so the paths that follow
# from the prefix (/etc, /lib/systemd/system: cmake/InstallConfigured.cmake) are those of /usr.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ONE_PER_GROUP)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE ${SHRM_DEB_RELEASE})
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${SHRM_DEB_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SOURCE shrm)
set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# Runtime dependencies from the programs' ELF files (dpkg-shlibdeps).
set(CPACK_DEBIAN_CLI_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_VIEWER_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_DAEMON_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_IMAGEIO_PACKAGE_SHLIBDEPS ON)
# The module is loaded, not linked: dpkg-shlibdeps cannot see it. The same build's, exactly.
set(SHRM_DEB_IMAGEIO_DEPENDS "shrm-imageio (= ${PROJECT_VERSION}-${SHRM_DEB_RELEASE})")
set(CPACK_DEBIAN_CLI_PACKAGE_DEPENDS "${SHRM_DEB_IMAGEIO_DEPENDS}")
set(CPACK_DEBIAN_VIEWER_PACKAGE_DEPENDS "${SHRM_DEB_IMAGEIO_DEPENDS}")
# The postinst creates the system user with systemd-sysusers, or adduser without systemd.
set(CPACK_DEBIAN_DAEMON_PACKAGE_DEPENDS "adduser, ${SHRM_DEB_IMAGEIO_DEPENDS}")
set(CPACK_DEBIAN_DAEMON_PACKAGE_SUGGESTS "shrm, nginx")
# The maintainer scripts of shrmd (as dh_installsystemd writes them) and its conffile.
set(SHRM_DEB_CONTROL ${PROJECT_BINARY_DIR}/install/daemon)
file(WRITE ${SHRM_DEB_CONTROL}/conffiles "/etc/shrmd/shrmd.conf\n")
set(CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_EXTRA ${SHRM_DEB_CONTROL}/conffiles)
foreach(script postinst prerm postrm)
  configure_file(${PROJECT_SOURCE_DIR}/deploy/debian/shrmd.${script} ${SHRM_DEB_CONTROL}/${script}
                 COPYONLY FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ
                                           GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
  list(APPEND CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_EXTRA ${SHRM_DEB_CONTROL}/${script})
endforeach()
# What find_package(shrm) and the pkg-config files find (cmake/shrmConfig.cmake.in).
set(CPACK_DEBIAN_DEVEL_PACKAGE_DEPENDS
    "${SHRM_DEB_IMAGEIO_DEPENDS}, libabsl-dev, libfftw3-dev, libopenexr-dev, zlib1g-dev, nlohmann-json3-dev, pkg-config")
if(TARGET shrm_client)
  string(APPEND CPACK_DEBIAN_DEVEL_PACKAGE_DEPENDS ", libgrpc++-dev, libprotobuf-dev")
endif()
set(CPACK_DEBIAN_DEVEL_PACKAGE_SUGGESTS "libcli11-dev, protobuf-compiler-grpc, shrm")

include(CPack)
foreach(group IN LISTS SHRM_DEB_PACKAGES)
  cpack_add_component_group(${group})
endforeach()
foreach(pair IN LISTS SHRM_DEB_COMPONENT_GROUPS)
  string(REPLACE ":" ";" pair "${pair}")
  list(GET pair 0 component)
  list(GET pair 1 group)
  cpack_add_component(${component} GROUP ${group})
endforeach()
