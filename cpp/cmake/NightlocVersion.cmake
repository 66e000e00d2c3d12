# The project's version is written once, in pyproject.toml ([project] version). Sets
#   NIGHTLOC_VERSION       numeric, for project(VERSION) and the CMake package version file
#   NIGHTLOC_VERSION_FULL  as written (e.g. 0.2.0rc1), for nightloc._core.__version__
# from scikit-build-core's SKBUILD_PROJECT_VERSION(_FULL) when it runs the build, else from
# pyproject.toml beside cpp/ (a plain CMake build of the core).
if(DEFINED SKBUILD_PROJECT_VERSION)
  set(NIGHTLOC_VERSION "${SKBUILD_PROJECT_VERSION}")
  if(DEFINED SKBUILD_PROJECT_VERSION_FULL)
    set(NIGHTLOC_VERSION_FULL "${SKBUILD_PROJECT_VERSION_FULL}")
  else()
    set(NIGHTLOC_VERSION_FULL "${SKBUILD_PROJECT_VERSION}")
  endif()
elseif(NOT DEFINED NIGHTLOC_VERSION)
  set(_nightloc_pyproject "${CMAKE_CURRENT_LIST_DIR}/../../pyproject.toml")
  if(NOT EXISTS "${_nightloc_pyproject}")
    message(FATAL_ERROR "nightloc: ${_nightloc_pyproject} (the project's version) not found; "
                        "pass -DNIGHTLOC_VERSION=X.Y.Z")
  endif()
  file(STRINGS "${_nightloc_pyproject}" _nightloc_version_line REGEX "^version *= *\"[^\"]+\"" LIMIT_COUNT 1)
  string(REGEX REPLACE "^version *= *\"([^\"]+)\".*" "\\1" NIGHTLOC_VERSION_FULL "${_nightloc_version_line}")
  string(REGEX MATCH "^[0-9]+(\\.[0-9]+)*" NIGHTLOC_VERSION "${NIGHTLOC_VERSION_FULL}")
  if(NOT NIGHTLOC_VERSION)
    message(FATAL_ERROR "nightloc: no [project] version found in ${_nightloc_pyproject}")
  endif()
endif()
if(NOT DEFINED NIGHTLOC_VERSION_FULL)
  set(NIGHTLOC_VERSION_FULL "${NIGHTLOC_VERSION}")
endif()
