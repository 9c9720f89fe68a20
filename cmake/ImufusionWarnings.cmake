# imufusion_set_warnings(target): the project's warning set; errors when IMUFUSION_WERROR is on.
function(imufusion_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion -Wnon-virtual-dtor)
  if(IMUFUSION_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
