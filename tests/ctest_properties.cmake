# CTest include file (tests/CMakeLists.txt writes the wrapper that sets ALC_TESTS_BINARY_DIR and
# ALC_SWEEP_MODULES): properties that catch_discover_tests cannot pass, a list as one value. Runs in
# the build's tests directory after the discovered tests are added.

# The supervisor's "nc loop: ..." tests hold both CTest locks, mqtt (a broker and `alc supervise`) and
# linuxcnc (the one LinuxCNC simulator of the machine).
file(GLOB _alc_supervisor_test_files "${ALC_TESTS_BINARY_DIR}/test_supervisor_tests-*.cmake")
foreach(_file IN LISTS _alc_supervisor_test_files)
  file(STRINGS "${_file}" _lines REGEX "^add_test\\(")
  foreach(_line IN LISTS _lines)
    if(_line MATCHES "^add_test\\( *\\[==\\[([^]]*nc loop: [^]]*)\\]==\\]")
      set_tests_properties("${CMAKE_MATCH_1}" PROPERTIES RESOURCE_LOCK "mqtt;linuxcnc")
    endif()
  endforeach()
endforeach()

# Tests tagged [sweep] (discovered into alc_sweep_<module>): their module's label and sweep.
foreach(_module IN LISTS ALC_SWEEP_MODULES)
  foreach(_test IN LISTS alc_sweep_${_module})
    set_tests_properties("${_test}" PROPERTIES LABELS "${_module};sweep")
  endforeach()
endforeach()
