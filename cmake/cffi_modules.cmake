# The Python extension modules: one per <package>/_build_cffi.py (cffi API mode), built by CMake
# like every other C target. The builder stays the one definition of its module (cdef, sources,
# flags); cmake/cffi_emit.py turns it into the generated C and a fragment of HIL_CFFI_* variables
# at configure time, and CMake re-runs it when the builder or a file it read (cdef/*.cdef)
# changes, or a folder it globbed (firmware_stub/src/) gains or loses a file.
#
# HIL_SANITIZE: the builder's make_builder(sanitize=True) (plus the global -fsanitize flags).
# HIL_PYTHON_INPLACE: after each build, also put the module next to its package's sources
# (copy + rename: a process that has the old module loaded keeps its file), which is where the
# development install (make build: an editable install of the Python only) imports it from.
#
# Included by the top-level CMakeLists.txt (HIL_ROOT) when HIL_PYTHON_MODULES is on.
find_package(Python 3.11 REQUIRED COMPONENTS Interpreter Development.Module)

file(GLOB HIL_CFFI_BUILDERS CONFIGURE_DEPENDS ${HIL_ROOT}/*/_build_cffi.py)
set(HIL_CFFI_TARGETS "")
foreach(builder ${HIL_CFFI_BUILDERS})
  get_filename_component(pkg_dir ${builder} DIRECTORY)
  get_filename_component(pkg ${pkg_dir} NAME)
  set(out ${CMAKE_BINARY_DIR}/cffi/${pkg})
  set(emit_args ${builder} ${out})
  if(HIL_SANITIZE)
    list(APPEND emit_args --sanitize)
  endif()
  execute_process(COMMAND ${Python_EXECUTABLE} ${HIL_ROOT}/cmake/cffi_emit.py ${emit_args}
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "cmake/cffi_emit.py ${builder} failed (needs cffi in ${Python_EXECUTABLE}):\n${err}")
  endif()
  include(${out}/module.cmake)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS
               ${HIL_ROOT}/cmake/cffi_emit.py ${HIL_CFFI_READ})
  foreach(dir ${HIL_CFFI_LISTED_DIRS})
    file(GLOB _hil_cffi_unused CONFIGURE_DEPENDS ${dir}/*)
  endforeach()

  set(target cffi_${pkg})
  Python_add_library(${target} MODULE WITH_SOABI ${HIL_CFFI_GENERATED} ${HIL_CFFI_SOURCES}
                     ${HIL_CFFI_EXTRA_OBJECTS})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME ${HIL_CFFI_NAME}
                        LIBRARY_OUTPUT_DIRECTORY ${out})
  target_include_directories(${target} PRIVATE ${HIL_CFFI_INCLUDE_DIRS})
  target_compile_definitions(${target} PRIVATE ${HIL_CFFI_DEFINES})
  target_compile_options(${target} PRIVATE ${HIL_CFFI_COMPILE_OPTIONS})
  target_link_options(${target} PRIVATE ${HIL_CFFI_LINK_OPTIONS})
  target_link_directories(${target} PRIVATE ${HIL_CFFI_LIBRARY_DIRS})
  target_link_libraries(${target} PRIVATE ${HIL_CFFI_LIBRARIES})
  install(TARGETS ${target} LIBRARY DESTINATION ${HIL_CFFI_DESTINATION} COMPONENT python)
  if(HIL_PYTHON_INPLACE)
    set(dest ${pkg_dir}/$<TARGET_FILE_NAME:${target}>)
    add_custom_command(TARGET ${target} POST_BUILD
      COMMAND ${CMAKE_COMMAND} -E copy $<TARGET_FILE:${target}> ${dest}.tmp
      COMMAND ${CMAKE_COMMAND} -E rename ${dest}.tmp ${dest}
      VERBATIM)
  endif()
  list(APPEND HIL_CFFI_TARGETS ${target})
endforeach()
