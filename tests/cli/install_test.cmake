# Installs the build tree into a scratch prefix and runs the installed
# photonfarm the way a user would (issue 17): --version names a version and a
# revision, `devices` lists a device, a small render writes its EXR.
#   cmake -DBUILD_DIR=... -DPREFIX=... -DSCENE=... -P install_test.cmake
file(REMOVE_RECURSE "${PREFIX}")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${PREFIX}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}): ${out}")
endif()
set(binary "${PREFIX}/bin/photonfarm")
if(NOT EXISTS "${binary}")
  message(FATAL_ERROR "no ${binary} after the install")
endif()
execute_process(COMMAND "${binary}" --version RESULT_VARIABLE rc OUTPUT_VARIABLE version)
if(NOT rc EQUAL 0 OR NOT version MATCHES "^photonfarm [0-9]+\\.[0-9]+\\.[0-9]+\\+[0-9a-z-]+\n$")
  message(FATAL_ERROR "photonfarm --version: exit ${rc}, printed '${version}'")
endif()
execute_process(COMMAND "${binary}" devices RESULT_VARIABLE rc OUTPUT_VARIABLE devices
                ERROR_VARIABLE devices)
if(NOT rc EQUAL 0 OR devices STREQUAL "")
  message(FATAL_ERROR "photonfarm devices: exit ${rc}: ${devices}")
endif()
execute_process(COMMAND "${binary}" render "${SCENE}" --frame 1 --size 8x6
                        -o "${PREFIX}/frame.exr"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0 OR NOT EXISTS "${PREFIX}/frame.exr")
  message(FATAL_ERROR "installed photonfarm render: exit ${rc}: ${out}")
endif()
message(STATUS "installed ${binary}: ${version}")
