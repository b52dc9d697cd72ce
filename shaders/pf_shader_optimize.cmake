# Script mode, run by the build for each shader after glslang (pf_shaders.cmake):
#   cmake -DINPUT=<x.spv.glslang> -DOUTPUT=<x.spv> -DNAME=<stem> -DSPIRV_OPT=<exe>
#         [-DCACHE_DIR=<dir>] -P pf_shader_optimize.cmake
# writes spirv-opt -O's module of INPUT to OUTPUT.
#
# Why optimise at all: Mesa's lavapipe (22.x) turns a pipeline's SPIR-V into NIR and
# optimises it in every process that creates the pipeline, and glslang's output (every
# function separate, every local a memory variable) is most of that work. A module that
# spirv-opt has inlined and put in SSA form is created ~2.6x faster (render_reference:
# 270 -> 100 ms), which is what a test or a worker's first frame waits for; the kernels run
# as fast, and their results differ by float rounding only (bench/RESULTS.md). spirv-opt
# keeps the specialisation constants, so every variant the renderer specialises is still
# one module.
#
# spirv-opt takes ~0.7 s a module, 30 s of a build on 2 cores. With CACHE_DIR the result is
# kept there as <NAME>-<key>.spv, the key the SHA-256 of the input and of spirv-opt's
# version and flags, so builds of the same sources in other directories (./bootstrap.sh
# test's plain, ASan and Release builds) copy it instead. A changed shader or tool is a new
# key, whose file replaces the shader's older ones: the cache holds one file a shader.
foreach(required INPUT OUTPUT NAME SPIRV_OPT)
  if(NOT DEFINED ${required})
    message(FATAL_ERROR "pf_shader_optimize.cmake: ${required} is required")
  endif()
endforeach()

set(flags --target-env=vulkan1.2 -O)
set(key "")
if(CACHE_DIR)
  execute_process(COMMAND "${SPIRV_OPT}" --version OUTPUT_VARIABLE version
                  RESULT_VARIABLE version_result ERROR_QUIET)
  if(version_result EQUAL 0)
    file(SHA256 "${INPUT}" input_hash)
    string(SHA256 key "${input_hash} ${version} ${flags}")
    set(cached "${CACHE_DIR}/${NAME}-${key}.spv")
    if(EXISTS "${cached}")
      # A copy that fails (another build replacing the file just now) optimises instead.
      file(COPY_FILE "${cached}" "${OUTPUT}" RESULT copy_result)
      if(copy_result EQUAL 0)
        return()
      endif()
    endif()
  endif()
endif()

execute_process(COMMAND "${SPIRV_OPT}" ${flags} "${INPUT}" -o "${OUTPUT}"
                RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  file(REMOVE "${OUTPUT}")
  message(FATAL_ERROR "spirv-opt failed on ${INPUT}")
endif()
if(key)
  # Written under a name of its own and renamed, so that a build reading the cache at the
  # same time never copies half a module.
  file(MAKE_DIRECTORY "${CACHE_DIR}")
  file(GLOB older "${CACHE_DIR}/${NAME}-*.spv")
  if(older)
    file(REMOVE ${older})
  endif()
  string(RANDOM LENGTH 8 nonce)
  file(COPY_FILE "${OUTPUT}" "${cached}.${nonce}.tmp")
  file(RENAME "${cached}.${nonce}.tmp" "${cached}")
endif()
