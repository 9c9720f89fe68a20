# The installed package as a user meets it. Run by CTest in one of three steps (-D STEP=...), with
# -D SOURCE_DIR, BINARY_DIR, WORK_DIR, GENERATOR, CXX_COMPILER and LIBRARY_TYPE (the imufusion
# target's TYPE: STATIC_LIBRARY or SHARED_LIBRARY):
#   install   installs the built tree into WORK_DIR/prefix; the installed CMake files must hold
#             no absolute path
#   consumer  configures, builds and runs tests/consumer/project against the prefix; for a shared
#             library with the dev packages of the private dependencies hidden from find_package
#   example   builds examples/ against the prefix, scans a small synthetic room with
#             scan_own_camera and checks its trajectory against ground truth and its mesh
#   python    (with -D PYTHON, the interpreter, and PYTHON_DIR, the module's directory relative
#             to the prefix) imports the installed module with PYTHONPATH set to that directory
#             alone, from outside the build tree, and reads a sequence it synthesizes
set(prefix ${WORK_DIR}/prefix)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message("${out}")
  set(run_output "${out}" PARENT_SCOPE)
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
  file(GLOB_RECURSE package_files ${prefix}/imufusion*.cmake)
  if(NOT package_files)
    message(FATAL_ERROR "no imufusion*.cmake installed under ${prefix}")
  endif()
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
elseif(STEP STREQUAL "example")
  build_outside(examples ${SOURCE_DIR}/examples)
  set(sequence ${WORK_DIR}/room)
  set(out ${WORK_DIR}/room_scan)
  run(${prefix}/bin/imufusion-synth --scene room --seed 3 --frames 40 --size 160x120
      --out ${sequence} --overwrite)
  run(${WORK_DIR}/examples/scan_own_camera ${sequence} ${out})
  if(NOT run_output MATCHES "^40 frames, 0 lost; mesh of ([0-9]+) vertices")
    message(FATAL_ERROR "scan_own_camera lost frames or printed no summary")
  endif()
  set(vertices ${CMAKE_MATCH_1})
  if(vertices LESS 2000)
    message(FATAL_ERROR "scan_own_camera's mesh has only ${vertices} vertices")
  endif()
  file(READ ${out}/mesh.ply header LIMIT 200)
  if(NOT header MATCHES "element vertex ${vertices}\n")
    message(FATAL_ERROR "mesh.ply does not hold the ${vertices} vertices printed:\n${header}")
  endif()
  run(${prefix}/bin/imufusion-eval ${sequence}/groundtruth.txt ${out}/trajectory.txt --json)
  string(JSON matched GET "${run_output}" matched)
  string(JSON ate GET "${run_output}" ate_rmse)
  if(NOT matched EQUAL 40 OR ate GREATER 0.015)
    message(FATAL_ERROR "scan_own_camera's trajectory: ${matched} of 40 poses matched, "
                        "ATE ${ate} m (at most 0.015 m)")
  endif()
  file(SIZE ${out}/preview.png preview_bytes)
  message("scan_own_camera: ATE ${ate} m over ${matched} frames, preview ${preview_bytes} bytes")
elseif(STEP STREQUAL "python")
  set(ENV{PYTHONPATH} ${prefix}/${PYTHON_DIR})
  set(check [=[
import os, sys, imufusion
prefix = os.path.realpath(sys.argv[1])
assert os.path.realpath(imufusion.__file__).startswith(prefix + os.sep), imufusion.__file__
imufusion.synthesize("python_room", frames=3, width=64, height=48, overwrite=True)
sequence = imufusion.SequenceReader("python_room")
config = imufusion.sequence_config(imufusion.SensorPreset.KINECT, sequence)
config.validate()
frame = next(sequence)
assert frame.depth.shape == (48, 64) and frame.depth.dtype.name == "uint16", frame.depth.shape
print("imported", imufusion.__file__, "version", imufusion.__version__)
]=])
  execute_process(COMMAND ${PYTHON} -c "${check}" ${prefix} WORKING_DIRECTORY ${WORK_DIR}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the installed module failed (${rc}) with PYTHONPATH=$ENV{PYTHONPATH}:\n"
                        "${out}\n${err}")
  endif()
  message("${out}")
else()
  message(FATAL_ERROR "unknown STEP '${STEP}'")
endif()
