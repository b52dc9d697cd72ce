# Proves that a shader compile error fails the build and names file and line:
# a scratch project uses shaders/pf_shaders.cmake on a shader whose line 6 is
# wrong, plus a shader that includes a common file whose line 3 is wrong.
#   cmake -DPF_SHADERS_CMAKE=<path> -DWORK_DIR=<dir> -DGENERATOR=<gen>
#         -DGLSLANG_VALIDATOR=<exe> -DSPIRV_VAL=<exe> -DSPIRV_OPT=<exe> -P shader_error_test.cmake
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}/src/common")
file(WRITE "${WORK_DIR}/src/CMakeLists.txt" "
cmake_minimum_required(VERSION 3.25)
project(shader_error_test LANGUAGES C)
set(GLSLANG_VALIDATOR \"${GLSLANG_VALIDATOR}\")
set(SPIRV_VAL \"${SPIRV_VAL}\")
set(SPIRV_OPT \"${SPIRV_OPT}\")
include(\"${PF_SHADERS_CMAKE}\")
pf_add_shader_library(scratch_shaders SOURCE_DIR \${CMAKE_SOURCE_DIR} INCLUDE_DIR \${CMAKE_SOURCE_DIR}/common)
")
file(WRITE "${WORK_DIR}/src/broken_line6.comp" "#version 460
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Values { uint values[]; };
void main()
{
    values[0] = undeclared_variable;
}
")
file(WRITE "${WORK_DIR}/src/common/helper.glsl" "// line 1
uint helper(uint x)
{ return x + missing_symbol; }
")
file(WRITE "${WORK_DIR}/src/uses_helper.comp" "#version 460
#extension GL_GOOGLE_include_directive : require
#include \"helper.glsl\"
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Values { uint values[]; };
void main() { values[0] = helper(values[0]); }
")

execute_process(COMMAND "${CMAKE_COMMAND}" -S "${WORK_DIR}/src" -B "${WORK_DIR}/build" -G "${GENERATOR}"
                RESULT_VARIABLE configure_result OUTPUT_VARIABLE configure_output ERROR_VARIABLE configure_output)
if(NOT configure_result EQUAL 0)
  message(FATAL_ERROR "scratch project did not configure:\n${configure_output}")
endif()
execute_process(COMMAND "${CMAKE_COMMAND}" --build "${WORK_DIR}/build" -- -k 0
                RESULT_VARIABLE build_result OUTPUT_VARIABLE build_output ERROR_VARIABLE build_output)
message(STATUS "build output:\n${build_output}")
if(build_result EQUAL 0)
  message(FATAL_ERROR "the build succeeded although two shaders are broken")
endif()
foreach(expected "broken_line6.comp:6:" "helper.glsl:3:")
  string(FIND "${build_output}" "${expected}" position)
  if(position EQUAL -1)
    message(FATAL_ERROR "the failed build does not name '${expected}'")
  endif()
endforeach()
message(STATUS "shader errors fail the build and name file:line")
