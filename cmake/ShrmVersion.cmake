# One version for everything (docs/install.md, "Versions"): the project version of the top-level
# CMakeLists.txt, the git revision of the checkout (refreshed at every build unless
# SHRM_GIT_REVISION_AT_BUILD=OFF; "unknown" outside git) and the conventions version, read from
# docs/conventions.md ("Conventions version: N").
#   shrm/version.h   generated header: SHRM_VERSION_*, shrm::kVersion, shrm::kConventionsVersion
#   shrm_version     the library that knows the git revision (shrm::GitRevision, VersionText)

file(STRINGS ${PROJECT_SOURCE_DIR}/docs/conventions.md SHRM_CONVENTIONS_LINE
     REGEX "^Conventions version: [0-9]+$" LIMIT_COUNT 1)
string(REGEX REPLACE "^Conventions version: ([0-9]+)$" "\\1" SHRM_CONVENTIONS_VERSION
       "${SHRM_CONVENTIONS_LINE}")
if(NOT SHRM_CONVENTIONS_VERSION MATCHES "^[0-9]+$")
  message(FATAL_ERROR "docs/conventions.md: no line 'Conventions version: N'")
endif()
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/conventions.md)

set(SHRM_GENERATED_DIR ${PROJECT_BINARY_DIR}/gen)
configure_file(${CMAKE_CURRENT_LIST_DIR}/version.h.in ${SHRM_GENERATED_DIR}/shrm/version.h @ONLY)

# The git revision: written by cmake/GitRevision.cmake at configure time and, with
# SHRM_GIT_REVISION_AT_BUILD, at every build too, but only when it changed (a build without a new
# commit or a first edit relinks nothing; one after it relinks the programs that print it).
option(SHRM_GIT_REVISION_AT_BUILD "Refresh the git revision at every build (OFF: at configure)" ON)
set(SHRM_GIT_REVISION_CC ${SHRM_GENERATED_DIR}/git_revision.cc)
execute_process(COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR}
                        -DOUTPUT=${SHRM_GIT_REVISION_CC} -P ${CMAKE_CURRENT_LIST_DIR}/GitRevision.cmake)
add_library(shrm_version STATIC ${SHRM_GIT_REVISION_CC})
if(SHRM_GIT_REVISION_AT_BUILD)
  add_custom_target(shrm_git_revision
    COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR} -DOUTPUT=${SHRM_GIT_REVISION_CC}
            -P ${CMAKE_CURRENT_LIST_DIR}/GitRevision.cmake
    BYPRODUCTS ${SHRM_GIT_REVISION_CC}
    COMMENT "git revision"
    VERBATIM)
  add_dependencies(shrm_version shrm_git_revision)
endif()
target_include_directories(shrm_version PUBLIC $<BUILD_INTERFACE:${SHRM_GENERATED_DIR}>)
add_library(shrm::version ALIAS shrm_version)
