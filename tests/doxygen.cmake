# Builds the public headers' reference with docs/Doxyfile (WARN_AS_ERROR = FAIL_ON_WARNINGS) into OUT, and fails on
# any warning or error, or when Doxygen is missing (tools/setup installs it).
if(NOT DOXYGEN)
  message(FATAL_ERROR "doxygen not found: tools/setup installs it (apt-get install doxygen)")
endif()
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
execute_process(COMMAND ${CMAKE_COMMAND} -E env GPISVDB_DOXYGEN_OUT=${OUT} ${DOXYGEN} docs/Doxyfile
                WORKING_DIRECTORY "${SOURCE}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT err STREQUAL "" OR NOT EXISTS "${OUT}/html/index.html")
  message(FATAL_ERROR "doxygen docs/Doxyfile ended with ${rc}:\n${err}${out}")
endif()
