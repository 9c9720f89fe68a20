# The installed package as a user meets it. Run by CTest in one of two steps (-D STEP=...), with
# -D SOURCE_DIR, BINARY_DIR, WORK_DIR, GENERATOR, CXX_COMPILER and LIBRARY_TYPE (the imufusion
# target's TYPE: STATIC_LIBRARY or SHARED_LIBRARY):
#   install   installs the built tree into WORK_DIR/prefix; the installed CMake files must hold
#             no absolute path
#   consumer  configures, builds and runs tests/consumer/project against the prefix; for a shared
#             library with the dev packages of the private dependencies hidden from find_package
set(prefix ${WORK_DIR}/prefix)
set(package_dir ${prefix}/lib/cmake/imufusion)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message("${out}")
endfunction()

# Configures and builds the outside project in `source` into WORK_DIR/<name>.
function(build_outside name source)
  file(REMOVE_RECURSE ${WORK_DIR}/${name})
  run(${CMAKE_COMMAND} -S ${source} -B ${WORK_DIR}/${name} -G ${GENERATOR}
      -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix}
      -DCMAKE_BUILD_TYPE=Release ${ARGN})
  run(${CMAKE_COMMAND} --build ${WORK_DIR}/${name})
endfunction()

if(STEP STREQUAL "install")
  file(REMOVE_RECURSE ${WORK_DIR})
  run(${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${prefix} --component Unspecified)
  # A path in a target property starts a value or follows ';' or a generator expression's ':'.
  file(GLOB package_files ${package_dir}/*.cmake)
  foreach(file ${package_files})
    file(STRINGS ${file} properties REGEX "^ *INTERFACE_|IMPORTED_")
    foreach(line ${properties})
      if(line MATCHES "[\";:]/")
        message(FATAL_ERROR "${file} names an absolute path: ${line}")
      endif()
    endforeach()
  endforeach()
elseif(STEP STREQUAL "consumer")
  set(hidden nlohmann_json)
  if(LIBRARY_TYPE STREQUAL "SHARED_LIBRARY")
    list(APPEND hidden Vulkan PNG Threads PkgConfig)
  endif()
  set(hide)
  foreach(package ${hidden})
    list(APPEND hide -DCMAKE_DISABLE_FIND_PACKAGE_${package}=ON)
  endforeach()
  build_outside(consumer ${SOURCE_DIR}/tests/consumer/project ${hide})
  run(${WORK_DIR}/consumer/consumer)
else()
  message(FATAL_ERROR "unknown STEP '${STEP}'")
endif()
