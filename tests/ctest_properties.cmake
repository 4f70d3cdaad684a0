# CTest include file (tests/CMakeLists.txt): the supervisor's "nc loop: ..." tests hold both CTest
# locks, mqtt (a broker and `alc supervise`) and linuxcnc (the one LinuxCNC simulator of the machine).
# Runs in the build's tests directory after the tests discovered by catch_discover_tests are added.
# ALC_TESTS_BINARY_DIR: set by the wrapper that tests/CMakeLists.txt writes into the build.
file(GLOB _alc_supervisor_test_files "${ALC_TESTS_BINARY_DIR}/test_supervisor_tests-*.cmake")
foreach(_file IN LISTS _alc_supervisor_test_files)
  file(STRINGS "${_file}" _lines REGEX "^add_test\\(")
  foreach(_line IN LISTS _lines)
    if(_line MATCHES "^add_test\\( *\\[==\\[([^]]*nc loop: [^]]*)\\]==\\]")
      set_tests_properties("${CMAKE_MATCH_1}" PROPERTIES RESOURCE_LOCK "mqtt;linuxcnc")
    endif()
  endforeach()
endforeach()
