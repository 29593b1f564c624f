# Included by the top-level CMakeLists.txt before any target. With
# RODMESH_SANITIZE=ON every target is compiled and linked with
# AddressSanitizer and UndefinedBehaviorSanitizer (undefined behaviour stops
# the program), for scripts/test-sanitizers.sh (docs/testing.md). gcc or
# clang.
#
# The translation units that instantiate the AD kernels (rodmesh_ad_sources)
# are compiled at -O1 whatever the build type: under the sanitizers, inlining
# the kernels at -O2 multiplies their compile time (about 25 CPU-minutes per
# translation unit before they were split), while -O1 keeps every check.
# scripts/test-sanitizers.sh builds everything at -O1.
option(RODMESH_SANITIZE "Build with AddressSanitizer and UndefinedBehaviorSanitizer (scripts/test-sanitizers.sh)" OFF)
if(RODMESH_SANITIZE)
  if(RODMESH_FUZZ)
    message(FATAL_ERROR "RODMESH_SANITIZE and RODMESH_FUZZ exclude each other (RODMESH_FUZZ already sanitizes)")
  endif()
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# Marks sources of the calling directory as AD-kernel instantiations.
function(rodmesh_ad_sources)
  if(RODMESH_SANITIZE)
    set_source_files_properties(${ARGN} PROPERTIES COMPILE_OPTIONS -O1)
  endif()
endfunction()
