# OpenNI2 (Debian: libopenni2-dev, pkg-config module libopenni2) reads live depth cameras
# (openni2://) and .oni recordings. Optional: a build without it still opens sequence
# directories, and openni2:// / .oni inputs fail with a message saying why. Found as the imported
# target PkgConfig::OPENNI2, which a static package's config finds again the same way.
option(IMUFUSION_WITH_OPENNI2 "Use OpenNI2 for live cameras and .oni recordings when found" ON)
set(IMUFUSION_HAVE_OPENNI2 OFF)
if(IMUFUSION_WITH_OPENNI2)
  find_package(PkgConfig QUIET)
  if(PKG_CONFIG_FOUND)
    pkg_check_modules(OPENNI2 QUIET IMPORTED_TARGET libopenni2)
  endif()
  if(OPENNI2_FOUND AND TARGET PkgConfig::OPENNI2)
    set(IMUFUSION_HAVE_OPENNI2 ON)
    message(STATUS "OpenNI2 ${OPENNI2_VERSION}: live cameras and .oni recordings enabled")
  else()
    message(STATUS "OpenNI2 not found (Debian: libopenni2-dev): openni2:// and .oni inputs "
                   "will report that this build lacks OpenNI2")
  endif()
endif()
