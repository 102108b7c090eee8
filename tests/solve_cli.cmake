# Runs the `solve` binary once and checks its exit code and messages.
#   cmake -DSOLVE=path -DDIR=workdir -DARGS="args" -DCODE=n -DMATCH=regex
#         [-DEXPECT_FILE=name] [-DABSENT_FILE=name] -P solve_cli.cmake
# ARGS is split like a shell command line; MATCH is searched in stdout and
# stderr together; EXPECT_FILE must exist in DIR afterwards, ABSENT_FILE
# must not.
separate_arguments(args UNIX_COMMAND "${ARGS}")
foreach(name IN ITEMS "${EXPECT_FILE}" "${ABSENT_FILE}")
  if(name)
    file(REMOVE "${DIR}/${name}")
  endif()
endforeach()
execute_process(COMMAND "${SOLVE}" ${args}
  WORKING_DIRECTORY "${DIR}"
  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "solve ${ARGS} -> ${code}\n${out}${err}")
if(NOT code STREQUAL "${CODE}")
  message(FATAL_ERROR "exit code ${code}, expected ${CODE}")
endif()
if(NOT "${out}${err}" MATCHES "${MATCH}")
  message(FATAL_ERROR "output does not match '${MATCH}'")
endif()
if(EXPECT_FILE AND NOT EXISTS "${DIR}/${EXPECT_FILE}")
  message(FATAL_ERROR "${EXPECT_FILE} was not written")
endif()
if(ABSENT_FILE AND EXISTS "${DIR}/${ABSENT_FILE}")
  message(FATAL_ERROR "${ABSENT_FILE} was written")
endif()
