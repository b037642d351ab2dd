# Install rules (docs/install.md): `cmake --install build --prefix DIR` and the Debian packages
# (cmake/ShrmPackaging.cmake) install the same files, by component:
#   shrm       bin/shrm (and LIBDIR/shrm/shrm-remote, which it runs for --server), its man
#              pages, bash completion, the bundled maps, the docs
#   shrmd      sbin/shrmd, shrmd(8), the systemd units, the sysusers file, etc/shrmd/shrmd.conf
#   shrm-view  bin/shrm-view, shrm-view(1), bash completion
#   imageio    LIBDIR/shrm/libshrm_imageio.so: OpenImageIO and OpenColorIO, loaded on demand
#   dev        the libraries (static, PIC), their headers (include/shrm), the proto file, the
#              CMake package (find_package(shrm): shrm::core, shrm::jobs, shrm::client) and the
#              pkg-config files (shrm-core, shrm-jobs, shrm-client)
# Nothing installed refers to the build or source tree.

# CMAKE_INSTALL_LIBDIR: Debian's multiarch folder (set in the top CMakeLists.txt).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(SHRM_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/shrm)
set(SHRM_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/shrm)
set(SHRM_WITH_CLIENT OFF)
if(TARGET shrm_client)
  set(SHRM_WITH_CLIENT ON)
endif()

# ---- The exported libraries -------------------------------------------------------------------
# shrm::core is the core in one name (core/*: SH, transforms, I/O, environment maps, BRDFs, SHRM
# synthesis, Prefilter()); shrm::jobs the job layer (jobs/); shrm::client the service's client
# library (client/, with the wire: proto/). The folders' own targets are exported too
# (shrm::sh, shrm::transform, shrm::io, shrm::envmap, shrm::brdf, shrm::shrm, shrm::base,
# shrm::version, shrm::proto, shrm::wire) for programs that want less than the whole core.
add_library(shrm_core INTERFACE)
target_link_libraries(shrm_core INTERFACE shrm_live shrm_ibl shrm_export shrm_shrm shrm_envmap shrm_brdf shrm_io shrm_transform
                                          shrm_sh shrm_base shrm_version)

set(SHRM_EXPORTED_TARGETS shrm_base shrm_version shrm_sh shrm_transform shrm_io shrm_envmap
                          shrm_brdf shrm_shrm shrm_ibl shrm_export shrm_live shrm_core shrm_jobs)
if(SHRM_WITH_CLIENT)
  list(APPEND SHRM_EXPORTED_TARGETS shrm_proto shrm_wire shrm_client)
endif()
foreach(target IN LISTS SHRM_EXPORTED_TARGETS)
  string(REGEX REPLACE "^shrm_" "" export_name ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
  if(NOT TARGET shrm::${export_name})  # the installed names inside the build too
    add_library(shrm::${export_name} ALIAS ${target})
  endif()
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "STATIC_LIBRARY")
    # Static libraries that plug-ins (shared objects) of content tools can link.
    set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  endif()
endforeach()

install(TARGETS ${SHRM_EXPORTED_TARGETS} EXPORT shrmTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
        INCLUDES DESTINATION ${SHRM_INSTALL_INCLUDEDIR})
install(EXPORT shrmTargets NAMESPACE shrm:: DESTINATION ${SHRM_INSTALL_CMAKEDIR} COMPONENT dev)
# The image I/O module (core/io/image_module.h), loaded at run time by every program and by
# programs that link shrm::io: LIBDIR/shrm/libshrm_imageio.so (package shrm-imageio).
install(TARGETS shrm_imageio LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/shrm COMPONENT imageio)

# Public headers, included as in the tree ("core/shrm/prefilter.h", "jobs/prefilter_job.h",
# "client/shrm_client.h", "shrm/v1/shrm.pb.h", "shrm/version.h") below include/shrm.
foreach(dir core jobs)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${SHRM_INSTALL_INCLUDEDIR}/${dir}
          COMPONENT dev FILES_MATCHING PATTERN "*.h")
endforeach()
install(FILES ${SHRM_GENERATED_DIR}/shrm/version.h DESTINATION ${SHRM_INSTALL_INCLUDEDIR}/shrm
        COMPONENT dev)
if(SHRM_WITH_CLIENT)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/client/ DESTINATION ${SHRM_INSTALL_INCLUDEDIR}/client
          COMPONENT dev FILES_MATCHING PATTERN "*.h")
  install(FILES ${PROJECT_SOURCE_DIR}/proto/job_codec.h ${PROJECT_SOURCE_DIR}/proto/status_details.h
          DESTINATION ${SHRM_INSTALL_INCLUDEDIR}/proto COMPONENT dev)
  # The protocol and its generated C++ (the client headers include it). The .proto sits where
  # protoc finds it with -I<includedir>/shrm, as Debian's own .proto files do.
  install(FILES ${PROJECT_SOURCE_DIR}/proto/shrm/v1/shrm.proto
                ${PROJECT_BINARY_DIR}/proto/gen/shrm/v1/shrm.pb.h
                ${PROJECT_BINARY_DIR}/proto/gen/shrm/v1/shrm.grpc.pb.h
          DESTINATION ${SHRM_INSTALL_INCLUDEDIR}/shrm/v1 COMPONENT dev)
endif()

# The CMake package: shrmConfig.cmake finds the Debian dependencies (find_dependency); the version
# file accepts a request for the same MAJOR.MINOR while the major version is 0, and for the same
# MAJOR from 1.0 on (docs/install.md, "Versions").
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(SHRM_VERSION_COMPATIBILITY SameMinorVersion)
else()
  set(SHRM_VERSION_COMPATIBILITY SameMajorVersion)
endif()
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/shrmConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/install/shrmConfig.cmake
                              INSTALL_DESTINATION ${SHRM_INSTALL_CMAKEDIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/install/shrmConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION}
                                 COMPATIBILITY ${SHRM_VERSION_COMPATIBILITY})
install(FILES ${PROJECT_BINARY_DIR}/install/shrmConfig.cmake
              ${PROJECT_BINARY_DIR}/install/shrmConfigVersion.cmake
        DESTINATION ${SHRM_INSTALL_CMAKEDIR} COMPONENT dev)

# ---- Files whose text names install paths ----------------------------------------------------
# The pkg-config files and the systemd units hold absolute paths. They are written at install
# time, from the prefix of that install (`cmake --install --prefix`, CPack's /usr), by
# cmake/InstallConfigured.cmake. With the prefix /usr, etc/ is /etc and the units go to
# /lib/systemd/system (Debian 12's systemdsystemunitdir), as GNUInstallDirs does for /etc.
# shrm_install_configured(TEMPLATE file RENAME name DIR {libdir/pkgconfig|sysconfdir/...|unitdir|
#                         sysusersdir} COMPONENT c): installs TEMPLATE with @SHRM_I_*@ replaced.
# glibc's vector math library, which shrm_brdf links where it exists (core/brdf/CMakeLists.txt).
set(SHRM_I_MVEC_FLAG "")
if(SHRM_MVEC_LIBRARY)
  set(SHRM_I_MVEC_FLAG "-lmvec")
endif()
function(shrm_install_configured)
  cmake_parse_arguments(ARG "" "TEMPLATE;RENAME;DIR;COMPONENT" "" ${ARGN})
  install(CODE "
    set(SHRM_I_VERSION \"${PROJECT_VERSION}\")
    set(SHRM_I_MVEC \"${SHRM_I_MVEC_FLAG}\")
    set(SHRM_I_LIBDIR_REL \"${CMAKE_INSTALL_LIBDIR}\")
    set(SHRM_I_INCLUDEDIR_REL \"${SHRM_INSTALL_INCLUDEDIR}\")
    set(SHRM_I_BINDIR_REL \"${CMAKE_INSTALL_BINDIR}\")
    set(SHRM_I_SBINDIR_REL \"${CMAKE_INSTALL_SBINDIR}\")
    set(SHRM_I_TEMPLATE \"${ARG_TEMPLATE}\")
    set(SHRM_I_RENAME \"${ARG_RENAME}\")
    set(SHRM_I_DIR \"${ARG_DIR}\")
    set(SHRM_I_WORK \"${PROJECT_BINARY_DIR}/install/configured\")
    include(\"${PROJECT_SOURCE_DIR}/cmake/InstallConfigured.cmake\")"
    COMPONENT ${ARG_COMPONENT})
endfunction()

foreach(pc shrm-core shrm-jobs)
  shrm_install_configured(TEMPLATE ${CMAKE_CURRENT_LIST_DIR}/pkgconfig/${pc}.pc.in RENAME ${pc}.pc
                          DIR libdir/pkgconfig COMPONENT dev)
endforeach()
if(SHRM_WITH_CLIENT)
  shrm_install_configured(TEMPLATE ${CMAKE_CURRENT_LIST_DIR}/pkgconfig/shrm-client.pc.in
                          RENAME shrm-client.pc DIR libdir/pkgconfig COMPONENT dev)
endif()

# ---- Programs, man pages, shell completion --------------------------------------------------
find_program(SHRM_HELP2MAN help2man)
find_program(SHRM_GZIP gzip)
option(SHRM_MANPAGES "Generate man pages with help2man from the programs' --help" ON)
set(SHRM_MANPAGE_DIR ${PROJECT_BINARY_DIR}/man)
# shrm_program(target COMPONENT c DESTINATION dir SECTION s [SEE_ALSO "a(1),b(8)"])
function(shrm_program target)
  cmake_parse_arguments(ARG "" "COMPONENT;DESTINATION;SECTION;SEE_ALSO" "" ${ARGN})
  install(TARGETS ${target} RUNTIME DESTINATION ${ARG_DESTINATION} COMPONENT ${ARG_COMPONENT})
  install(FILES ${PROJECT_SOURCE_DIR}/deploy/bash-completion/shrm
          DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions RENAME ${target}
          COMPONENT ${ARG_COMPONENT})
  if(SHRM_MANPAGES AND SHRM_HELP2MAN AND SHRM_GZIP)
    set(out ${SHRM_MANPAGE_DIR}/${target})
    add_custom_command(
      OUTPUT ${out}/stamp
      COMMAND ${CMAKE_COMMAND} -DHELP2MAN=${SHRM_HELP2MAN} -DGZIP=${SHRM_GZIP}
              -DPROGRAM=$<TARGET_FILE:${target}> -DNAME=${target} -DSECTION=${ARG_SECTION}
              -DVERSION=${PROJECT_VERSION} -DOUT_DIR=${out} -DSEE_ALSO=${ARG_SEE_ALSO}
              -P ${PROJECT_SOURCE_DIR}/cmake/ManPages.cmake
      COMMAND ${CMAKE_COMMAND} -E touch ${out}/stamp
      DEPENDS ${target} ${PROJECT_SOURCE_DIR}/cmake/ManPages.cmake
      COMMENT "help2man: ${target}"
      VERBATIM)
    add_custom_target(${target}_man ALL DEPENDS ${out}/stamp)
    install(DIRECTORY ${out}/man${ARG_SECTION} DESTINATION ${CMAKE_INSTALL_MANDIR}
            COMPONENT ${ARG_COMPONENT} FILES_MATCHING PATTERN "*.${ARG_SECTION}.gz")
  endif()
endfunction()
if(SHRM_MANPAGES AND NOT (SHRM_HELP2MAN AND SHRM_GZIP))
  message(STATUS "help2man or gzip not found: no man pages (scripts/install-deps.sh installs them)")
endif()

if(TARGET shrm)
  shrm_program(shrm COMPONENT shrm DESTINATION ${CMAKE_INSTALL_BINDIR} SECTION 1
               SEE_ALSO "shrmd(8),shrm-view(1)")
endif()
if(TARGET shrm-remote)
  # `shrm` with the service client, which `shrm` runs for --server (cli/CMakeLists.txt): an
  # internal program, beside the image module (no man page, not on PATH).
  install(TARGETS shrm-remote RUNTIME DESTINATION ${CMAKE_INSTALL_LIBDIR}/shrm COMPONENT shrm)
endif()
if(TARGET shrm-view)
  shrm_program(shrm-view COMPONENT shrm-view DESTINATION ${CMAKE_INSTALL_BINDIR} SECTION 1
               SEE_ALSO "shrm(1),shrmd(8)")
endif()
if(TARGET shrmd)
  # A system daemon: sbin and section 8, as Debian's daemons.
  shrm_program(shrmd COMPONENT shrmd DESTINATION ${CMAKE_INSTALL_SBINDIR} SECTION 8
               SEE_ALSO "shrm(1),systemd.service(5)")
  # deploy/systemd: the units (ExecStart= names this install's shrmd and shrmd.conf), the system
  # user shrmd (sysusers.d) and the daemon's settings.
  foreach(unit shrmd.service shrmd@.service)
    shrm_install_configured(TEMPLATE ${PROJECT_SOURCE_DIR}/deploy/systemd/${unit} RENAME ${unit}
                            DIR unitdir COMPONENT shrmd)
  endforeach()
  shrm_install_configured(TEMPLATE ${PROJECT_SOURCE_DIR}/deploy/systemd/shrmd.sysusers.conf
                          RENAME shrmd.conf DIR sysusersdir COMPONENT shrmd)
  shrm_install_configured(TEMPLATE ${PROJECT_SOURCE_DIR}/deploy/systemd/shrmd.conf
                          RENAME shrmd.conf DIR sysconfdir/shrmd COMPONENT shrmd)
endif()

# ---- Data and documentation (the shrm package) ------------------------------------------------
install(FILES ${PROJECT_SOURCE_DIR}/data/envmaps/city.exr ${PROJECT_SOURCE_DIR}/data/envmaps/courtyard.exr
              ${PROJECT_SOURCE_DIR}/data/envmaps/forest.exr
              ${PROJECT_SOURCE_DIR}/data/envmaps/interior.exr
              ${PROJECT_SOURCE_DIR}/data/envmaps/README.md
        DESTINATION ${CMAKE_INSTALL_DATADIR}/shrm/envmaps COMPONENT shrm)
# The shader library (docs/shaders.md), for engines to copy.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/shaders/glsl ${PROJECT_SOURCE_DIR}/shaders/wgsl
        DESTINATION ${CMAKE_INSTALL_DATADIR}/shrm/shaders COMPONENT shrm)
install(FILES ${PROJECT_SOURCE_DIR}/data/ocio/config.ocio
        DESTINATION ${CMAKE_INSTALL_DATADIR}/shrm/ocio COMPONENT shrm)
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT shrm)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs
        COMPONENT shrm FILES_MATCHING PATTERN "*.md" PATTERN "*.png")
# The licenses (shrm's, the maps'): a plain install carries the files; the Debian packages carry
# them in their copyright files instead (deploy/debian/copyright), so this component is not
# packaged.
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT license)
install(FILES ${PROJECT_SOURCE_DIR}/data/envmaps/LICENSE.txt
        DESTINATION ${CMAKE_INSTALL_DATADIR}/shrm/envmaps COMPONENT license)
