# Runs the Catch2 executable EXE as CTest's discovery does, and fails unless it lists test cases (Catch2 2.13
# exits with the number of cases listed; a crash gives a message instead of a number).
execute_process(COMMAND "${EXE}" --list-test-names-only RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc MATCHES "^[0-9]+$" OR NOT out MATCHES "band: ")
  message(FATAL_ERROR "${EXE} --list-test-names-only ended with '${rc}' and listed no test case: CTest has "
                      "discovered none of them.\n${err}")
endif()
