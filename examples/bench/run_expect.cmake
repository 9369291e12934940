# Runs PROGRAM with ARGS (one string, split as a Unix shell would) and fails
# unless it exits 0 and its standard output matches the regular expression
# EXPECT. Used by tests that need both, since PASS_REGULAR_EXPRESSION ignores
# the exit status.
#   cmake -DPROGRAM=path -DARGS="..." -DEXPECT=regex -P run_expect.cmake
separate_arguments(_args UNIX_COMMAND "${ARGS}")
execute_process(COMMAND "${PROGRAM}" ${_args}
  RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
message("${_out}")
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} exited with ${_rc}:\n${_err}")
endif()
if(NOT _out MATCHES "${EXPECT}")
  message(FATAL_ERROR "the output of ${PROGRAM} does not match '${EXPECT}'")
endif()
