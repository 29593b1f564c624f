# Included by the top-level CMakeLists.txt before any target: with
# RODMESH_FUZZ=ON every target is compiled for libFuzzer coverage and with
# AddressSanitizer and UndefinedBehaviorSanitizer, and fuzz/ is added.
option(RODMESH_FUZZ "Build the libFuzzer harnesses in fuzz/ (clang only; see scripts/fuzz.sh)" OFF)
if(RODMESH_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "RODMESH_FUZZ=ON needs clang (libFuzzer): configure with CC=clang CXX=clang++")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=address,undefined)
endif()
