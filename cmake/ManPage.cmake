# cmake -DPROGRAM=... -DHELP2MAN=... -DEPOCH=... -DOUT=.../isoslab.1 -P ManPage.cmake
# Writes OUT (help2man from `isoslab --help`, with a COMMANDS section that holds every command's
# own --help) and OUT.gz (gzip -9n, as Debian installs man pages).
execute_process(COMMAND ${PROGRAM} --help OUTPUT_VARIABLE top RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "ManPage: ${PROGRAM} --help failed")
endif()
# The command names: the lines of the Subcommands list.
string(REGEX MATCH "Subcommands:\n(.*)" list "${top}")
string(REGEX MATCHALL "\n  ([a-z]+) " names "\n${CMAKE_MATCH_1}")
set(include "[COMMANDS]\nEach command has its own options; `isoslab COMMAND --help' prints them.\n")
foreach(entry ${names})
  string(STRIP "${entry}" name)
  execute_process(COMMAND ${PROGRAM} ${name} --help OUTPUT_VARIABLE help RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "ManPage: ${PROGRAM} ${name} --help failed")
  endif()
  # roff: a backslash is \e; a line that starts with . or ' would be a request. help2man's include
  # file: a line that starts with [ would open a section, one that starts with / a placement rule.
  string(REPLACE "\\" "\\e" help "${help}")
  string(REGEX REPLACE "(^|\n)([.'[/])" "\\1\\\\&\\2" help "${help}")
  if(NOT help MATCHES "\n$")
    string(APPEND help "\n")
  endif()
  string(APPEND include ".SS ${name}\n.nf\n${help}.fi\n")
endforeach()
string(APPEND include "[SEE ALSO]\nThe README and docs/ of the source tree; the Python package \\fBisoslab\\fR.\n")
file(WRITE ${OUT}.include "${include}")
set(ENV{SOURCE_DATE_EPOCH} ${EPOCH})
execute_process(COMMAND ${HELP2MAN} --no-info --no-discard-stderr
                        "--name=streaming iso-surface extraction from volumetric scanner data"
                        --include=${OUT}.include --output=${OUT} ${PROGRAM}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "ManPage: help2man failed")
endif()
execute_process(COMMAND gzip -9n -c ${OUT} OUTPUT_FILE ${OUT}.gz RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "ManPage: gzip failed")
endif()
