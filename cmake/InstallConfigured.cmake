# Install-time part of shrm_install_configured (cmake/ShrmInstall.cmake): writes SHRM_I_TEMPLATE
# with the paths of this install (CMAKE_INSTALL_PREFIX is the prefix given to `cmake --install`,
# or CPack's /usr) and installs it as SHRM_I_DIR/SHRM_I_RENAME (DESTDIR applies).
string(REGEX REPLACE "/+$" "" SHRM_I_PREFIX "${CMAKE_INSTALL_PREFIX}")
if(SHRM_I_PREFIX STREQUAL "/usr")
  # Debian 12: configuration in /etc, units in /lib/systemd/system (pkg-config systemd
  # systemdsystemunitdir), sysusers.d in /usr/lib.
  set(SHRM_I_SYSCONFDIR "/etc")
  set(SHRM_I_UNITDIR "/lib/systemd/system")
  set(SHRM_I_SYSUSERSDIR "/usr/lib/sysusers.d")
else()
  set(SHRM_I_SYSCONFDIR "${SHRM_I_PREFIX}/etc")
  set(SHRM_I_UNITDIR "${SHRM_I_PREFIX}/lib/systemd/system")
  set(SHRM_I_SYSUSERSDIR "${SHRM_I_PREFIX}/lib/sysusers.d")
endif()
set(SHRM_I_LIBDIR "${SHRM_I_PREFIX}/${SHRM_I_LIBDIR_REL}")
set(SHRM_I_INCLUDEDIR "${SHRM_I_PREFIX}/${SHRM_I_INCLUDEDIR_REL}")
set(SHRM_I_SHRMD "${SHRM_I_PREFIX}/${SHRM_I_SBINDIR_REL}/shrmd")

if(SHRM_I_DIR STREQUAL "unitdir")
  set(dest "${SHRM_I_UNITDIR}")
elseif(SHRM_I_DIR STREQUAL "sysusersdir")
  set(dest "${SHRM_I_SYSUSERSDIR}")
elseif(SHRM_I_DIR MATCHES "^sysconfdir(/.*)?$")
  set(dest "${SHRM_I_SYSCONFDIR}${CMAKE_MATCH_1}")
elseif(SHRM_I_DIR MATCHES "^libdir(/.*)?$")
  set(dest "${SHRM_I_LIBDIR}${CMAKE_MATCH_1}")
else()
  message(FATAL_ERROR "InstallConfigured.cmake: unknown DIR ${SHRM_I_DIR}")
endif()

file(READ "${SHRM_I_TEMPLATE}" text)
if(SHRM_I_DIR STREQUAL "unitdir")
  # deploy/systemd's units name the paths of a manual install (deploy/systemd/README.md).
  string(REPLACE "/usr/local/bin/shrmd" "${SHRM_I_SHRMD}" text "${text}")
  string(REPLACE "/etc/shrmd/shrmd.conf" "${SHRM_I_SYSCONFDIR}/shrmd/shrmd.conf" text "${text}")
else()
  string(CONFIGURE "${text}" text @ONLY)
endif()
string(RANDOM LENGTH 12 tag)
set(tmp_dir "${SHRM_I_WORK}/${tag}")
file(WRITE "${tmp_dir}/${SHRM_I_RENAME}" "${text}")
file(INSTALL DESTINATION "${dest}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
     FILES "${tmp_dir}/${SHRM_I_RENAME}")
file(REMOVE_RECURSE "${tmp_dir}")
