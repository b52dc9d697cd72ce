# ctest script: runs GENERATOR into OUT_DIR (twice, to catch output that varies
# between runs) and requires every file it writes to equal the one committed
# under SCENES_DIR.
foreach(var GENERATOR SCENES_DIR OUT_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "scenes_match.cmake: -D${var}=... is required")
  endif()
endforeach()

file(MAKE_DIRECTORY "${OUT_DIR}")
foreach(run first second)
  file(REMOVE_RECURSE "${OUT_DIR}/${run}")
  execute_process(COMMAND "${GENERATOR}" "${OUT_DIR}/${run}" RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${GENERATOR} ${OUT_DIR}/${run} failed: ${status}")
  endif()
endforeach()

file(GLOB_RECURSE generated RELATIVE "${OUT_DIR}/first" "${OUT_DIR}/first/*")
list(LENGTH generated generated_count)
if(generated_count EQUAL 0)
  message(FATAL_ERROR "${GENERATOR} wrote no files")
endif()
foreach(file IN LISTS generated)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files
    "${OUT_DIR}/first/${file}" "${OUT_DIR}/second/${file}" RESULT_VARIABLE differs)
  if(differs)
    message(FATAL_ERROR "scenes/${file}: two runs of the generator differ")
  endif()
  if(NOT EXISTS "${SCENES_DIR}/${file}")
    message(FATAL_ERROR "scenes/${file} is generated but not committed: "
      "run `cmake --build BUILD --target pf_regenerate_scenes`")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files
    "${OUT_DIR}/first/${file}" "${SCENES_DIR}/${file}" RESULT_VARIABLE differs)
  if(differs)
    message(FATAL_ERROR "scenes/${file} differs from the generator's output: "
      "edit scenes/generate_scenes.c, never the file, and run "
      "`cmake --build BUILD --target pf_regenerate_scenes`")
  endif()
  message(STATUS "scenes/${file}: matches the generator")
endforeach()
