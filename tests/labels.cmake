# Labels of the gtest tests (docs/testing.md, "Fast and slow tests"), read by ctest after the
# tests gtest_discover_tests found (weft_tests_TESTS): those named in tests/slow_tests.txt
# (WEFT_SLOW_TEST_LIST) are `slow`, every other one `fast`. ctest reads the list each time, so
# moving a test between the two needs no reconfiguring. tools/check_test_labels.py (ctest:
# test_labels) checks that every test has exactly one of the labels and that each name in the
# list is a test.
file(STRINGS "${WEFT_SLOW_TEST_LIST}" _weft_slow_lines)
set(_weft_slow "")
foreach(_line IN LISTS _weft_slow_lines)
  string(STRIP "${_line}" _line)
  if(_line AND NOT _line MATCHES "^#")
    list(APPEND _weft_slow "${_line}")
  endif()
endforeach()
foreach(_test IN LISTS weft_tests_TESTS)
  list(FIND _weft_slow "${_test}" _at)  # (ctest's scripts run without IN_LIST's policy)
  if(_at GREATER -1)
    set_tests_properties("${_test}" PROPERTIES LABELS slow)
  else()
    set_tests_properties("${_test}" PROPERTIES LABELS fast)
  endif()
endforeach()
