# With IMUFUSION_SANITIZE, every target in the tree is built and linked with ASan + UBSan.
if(IMUFUSION_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
