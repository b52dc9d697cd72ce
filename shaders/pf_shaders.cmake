# pf_add_shader_library(<target> SOURCE_DIR <dir> INCLUDE_DIR <dir>)
#
# Compiles every <SOURCE_DIR>/*.comp to SPIR-V with
#   glslangValidator -V --target-env vulkan1.2 -I<INCLUDE_DIR>
# optimises it with spirv-opt -O (pf_shader_optimize.cmake says why; PF_SHADER_CACHE_DIR,
# when set, keeps the results for other build directories), checks each module with
# `spirv-val --target-env vulkan1.2`, and embeds them all into the static library
# <target>, whose generated header pf_shaders.h offers pf_shader_find("<file stem>").
#
# A shader with a line `// pf-variant: <suffix> <MACRO>` is compiled a second
# time with -D<MACRO>, embedded as "<stem>_<suffix>" (the kernels' textured
# variant: a scene without textures runs, and compiles, none of that code).
#
# The glob is CONFIGURE_DEPENDS, so a new shader needs no CMake edit. Each
# shader rebuilds when it, anything it includes (glslang's depfile), or any
# <INCLUDE_DIR>/*.glsl changes. A compile error fails the build with glslang's
# "ERROR: <file>:<line>: ..." line. Uses GLSLANG_VALIDATOR, SPIRV_OPT and SPIRV_VAL
# when the caller found them, else looks them up.

# Script mode, run by the build for each shader:
#   cmake -DINPUT=<x.spv> -DOUTPUT=<x.spv.c> -DNAME=<stem> -DSYMBOL=<c identifier> -P pf_shaders.cmake
# writes the SPIR-V module as a C array of 32-bit words plus its pf_shader_blob.
# SPIR-V is a stream of 32-bit words and glslang writes them in host (little-
# endian) byte order, so each 4-byte group is reassembled least significant first.
if(CMAKE_SCRIPT_MODE_FILE)
  file(READ "${INPUT}" hex HEX)
  string(LENGTH "${hex}" hex_length)
  math(EXPR byte_count "${hex_length} / 2")
  math(EXPR remainder "${byte_count} % 4")
  if(byte_count EQUAL 0 OR NOT remainder EQUAL 0)
    message(FATAL_ERROR "${INPUT}: ${byte_count} bytes is not a SPIR-V module (a nonzero multiple of 4)")
  endif()
  string(REGEX REPLACE "([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])"
         "0x\\4\\3\\2\\1u," words "${hex}")
  # Eight words per line keeps the generated file readable in a debugger.
  string(REGEX REPLACE "((0x[0-9a-f]+u,){8})" "\\1\n    " words "${words}")
  file(WRITE "${OUTPUT}" "/* Generated from ${NAME}.spv by shaders/pf_shaders.cmake. */
#include \"pf_shaders.h\"

static const uint32_t words[] = {
    ${words}
};

const pf_shader_blob pf_shader_blob_${SYMBOL} = {\"${NAME}\", words, sizeof words};
")
  return()
endif()

include_guard(GLOBAL)

function(pf_add_shader_library target)
  # This file, run in script mode by the build (a variable set beside the include_guard
  # would be seen only in the directory that included the file first).
  set(embed_script "${CMAKE_CURRENT_FUNCTION_LIST_FILE}")
  get_filename_component(script_dir "${CMAKE_CURRENT_FUNCTION_LIST_FILE}" DIRECTORY)
  set(optimize_script "${script_dir}/pf_shader_optimize.cmake")
  cmake_parse_arguments(S "" "SOURCE_DIR;INCLUDE_DIR" "" ${ARGN})
  if(NOT S_SOURCE_DIR OR NOT S_INCLUDE_DIR)
    message(FATAL_ERROR "pf_add_shader_library(${target}): SOURCE_DIR and INCLUDE_DIR are required")
  endif()
  if(NOT GLSLANG_VALIDATOR)
    find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)
  endif()
  if(NOT SPIRV_VAL)
    find_program(SPIRV_VAL spirv-val REQUIRED)
  endif()
  if(NOT SPIRV_OPT)
    find_program(SPIRV_OPT spirv-opt REQUIRED)
  endif()

  file(GLOB shader_sources CONFIGURE_DEPENDS "${S_SOURCE_DIR}/*.comp")
  file(GLOB shader_includes CONFIGURE_DEPENDS "${S_INCLUDE_DIR}/*.glsl")
  list(SORT shader_sources)

  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/${target}")
  file(MAKE_DIRECTORY "${out_dir}")
  set(generated_sources)
  set(declarations "")
  set(entries "")
  set(builds)
  foreach(source IN LISTS shader_sources)
    get_filename_component(stem "${source}" NAME_WE)
    list(APPEND builds "${source}|${stem}|")
    file(STRINGS "${source}" variant_lines REGEX "^// pf-variant: [a-z_]+ [A-Z_]+$")
    foreach(line IN LISTS variant_lines)
      string(REGEX REPLACE "^// pf-variant: ([a-z_]+) ([A-Z_]+)$" "\\1;\\2" variant "${line}")
      list(GET variant 0 suffix)
      list(GET variant 1 macro)
      list(APPEND builds "${source}|${stem}_${suffix}|-D${macro}")
    endforeach()
  endforeach()
  foreach(build IN LISTS builds)
    string(REPLACE "|" ";" fields "${build}")
    list(GET fields 0 source)
    list(GET fields 1 stem)
    list(LENGTH fields field_count)
    set(define)
    if(field_count GREATER 2)
      list(GET fields 2 define)
    endif()
    string(MAKE_C_IDENTIFIER "${stem}" symbol)
    set(spv "${out_dir}/${stem}.spv")
    set(embedded "${out_dir}/${stem}.spv.c")
    add_custom_command(
      OUTPUT "${spv}"
      COMMAND "${GLSLANG_VALIDATOR}" -V --target-env vulkan1.2 "-I${S_INCLUDE_DIR}" ${define}
              --depfile "${spv}.d" -o "${spv}.glslang" "${source}"
      COMMAND "${CMAKE_COMMAND}" "-DINPUT=${spv}.glslang" "-DOUTPUT=${spv}" "-DNAME=${stem}"
              "-DSPIRV_OPT=${SPIRV_OPT}" "-DCACHE_DIR=${PF_SHADER_CACHE_DIR}"
              -P "${optimize_script}"
      COMMAND "${SPIRV_VAL}" --target-env vulkan1.2 "${spv}"
      DEPENDS "${source}" ${shader_includes} "${optimize_script}"
      DEPFILE "${spv}.d"
      COMMENT "Compiling shader ${stem} (${source})"
      VERBATIM)
    add_custom_command(
      OUTPUT "${embedded}"
      COMMAND "${CMAKE_COMMAND}" "-DINPUT=${spv}" "-DOUTPUT=${embedded}"
              "-DNAME=${stem}" "-DSYMBOL=${symbol}" -P "${embed_script}"
      DEPENDS "${spv}" "${embed_script}"
      COMMENT "Embedding shader ${stem}.spv"
      VERBATIM)
    list(APPEND generated_sources "${embedded}")
    string(APPEND declarations "extern const pf_shader_blob pf_shader_blob_${symbol};\n")
    string(APPEND entries "    &pf_shader_blob_${symbol},\n")
  endforeach()

  file(CONFIGURE OUTPUT "${out_dir}/pf_shaders.h" @ONLY CONTENT [==[
/* Generated by shaders/pf_shaders.cmake: the SPIR-V of every shader in shaders/. */
#ifndef PF_SHADERS_H
#define PF_SHADERS_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    const char *name;       /* file stem, e.g. "raycast_brute" */
    const uint32_t *words;  /* SPIR-V, validated by spirv-val at build time */
    size_t bytes;
} pf_shader_blob;

/* The embedded shader with this name, or NULL when there is none. */
const pf_shader_blob *pf_shader_find(const char *name);

/* The index-th embedded shader (in file-name order), or NULL past the last. */
const pf_shader_blob *pf_shader_at(size_t index);

#endif
]==])

  # The blob table is rebuilt at configure time, which the CONFIGURE_DEPENDS
  # glob triggers whenever a shader is added or removed.
  file(CONFIGURE OUTPUT "${out_dir}/pf_shaders_table.c" @ONLY CONTENT [==[
/* Generated by shaders/pf_shaders.cmake. */
#include "pf_shaders.h"

#include <string.h>

@declarations@
static const pf_shader_blob *const blobs[] = {
@entries@    NULL,
};

const pf_shader_blob *pf_shader_find(const char *name)
{
    for (size_t i = 0; name && blobs[i]; i++) {
        if (!strcmp(blobs[i]->name, name))
            return blobs[i];
    }
    return NULL;
}

const pf_shader_blob *pf_shader_at(size_t index)
{
    return index < sizeof blobs / sizeof *blobs ? blobs[index] : NULL;
}
]==])

  add_library(${target} STATIC "${out_dir}/pf_shaders_table.c" ${generated_sources})
  target_include_directories(${target} PUBLIC "${out_dir}")
endfunction()
