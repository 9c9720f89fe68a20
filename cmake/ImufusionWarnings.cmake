# imufusion_set_warnings(target): the project's warning set; errors when IMUFUSION_WERROR is on.
function(imufusion_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion -Wnon-virtual-dtor)
  # GCC 12 reports -Wrestrict false positives inside libstdc++'s std::string concatenation at -O2
  # (GCC bug 105651); the warning stays on elsewhere.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(IMUFUSION_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
