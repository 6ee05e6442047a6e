# pip builds a wheel in a throw-away environment (build isolation): Eigen and
# pybind11 sit under a new /tmp/pip-build-env-*/ path on every `pip install .`.
# The compile commands name that path, so Ninja saw every command change and
# recompiled everything, although the persistent build directory
# (pyproject.toml: build-dir) held up-to-date objects. Here an imported
# target's include directories are replaced by a copy inside the build
# directory, refreshed file by file only where a header's content changed (a
# file left alone keeps its time stamp): the commands stay the same from one
# install to the next, and Ninja recompiles only what the checkout changed.
function(ibvs_stable_includes target name)
  get_target_property(_dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  set(_stable "")
  set(_i 0)
  foreach(_dir IN LISTS _dirs)
    set(_copy "${CMAKE_BINARY_DIR}/isolated-includes/${name}${_i}")
    file(GLOB_RECURSE _files RELATIVE "${_dir}" "${_dir}/*")
    foreach(_f IN LISTS _files)
      get_filename_component(_sub "${_copy}/${_f}" DIRECTORY)
      file(MAKE_DIRECTORY "${_sub}")
      file(COPY_FILE "${_dir}/${_f}" "${_copy}/${_f}" ONLY_IF_DIFFERENT)
    endforeach()
    list(APPEND _stable "${_copy}")
    math(EXPR _i "${_i} + 1")
  endforeach()
  set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_stable}")
  message(STATUS "ibvs: ${name} headers copied to ${CMAKE_BINARY_DIR}/isolated-includes (stable paths for incremental wheel builds)")
endfunction()
