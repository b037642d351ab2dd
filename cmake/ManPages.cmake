# cmake -DHELP2MAN=... -DGZIP=... -DPROGRAM=path -DNAME=shrm -DSECTION=1 -DVERSION=0.1.0
#       -DOUT_DIR=dir [-DSEE_ALSO="shrmd(8),shrm-view(1)"] -P ManPages.cmake
# The man pages of one program, made by help2man from its --help (the same option descriptions):
# OUT_DIR/manS/NAME.S.gz and, for a program with subcommands ("Subcommands:" in its --help),
# one page per subcommand, OUT_DIR/manS/NAME-SUB.S.gz (as git does: `man shrm-prefilter`).
# Pages are compressed with gzip -9n (Debian policy 12.1).
cmake_minimum_required(VERSION 3.25)
unset(ENV{TMPDIR})  # shrmd's --spool-dir default is $TMPDIR/shrmd-spool: print the plain default
set(ENV{LC_ALL} C.UTF-8)

execute_process(COMMAND "${PROGRAM}" --help OUTPUT_VARIABLE help RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} --help failed (${rc})")
endif()
# "NAME: what it is" on the first line is the NAME section's description.
string(REGEX MATCH "^[^\n]*" first_line "${help}")
string(REGEX REPLACE "^[^:]*: *" "" description "${first_line}")
string(REGEX REPLACE "[.]$" "" description "${description}")

# Subcommands and their one-line descriptions.
set(subcommands "")
string(REGEX MATCH "\nSubcommands:\n(  [^\n]*\n?)+" block "${help}")
if(block)
  string(REPLACE "\n" ";" lines "${block}")
  foreach(line IN LISTS lines)
    if(line MATCHES "^  ([a-z][a-z0-9-]*) +(.*)$")
      list(APPEND subcommands "${CMAKE_MATCH_1}")
      set(sub_description_${CMAKE_MATCH_1} "${CMAKE_MATCH_2}")
    endif()
  endforeach()
endif()

set(page_dir "${OUT_DIR}/man${SECTION}")
file(REMOVE_RECURSE "${page_dir}")
file(MAKE_DIRECTORY "${page_dir}")

# help2man with an include file: the SEE ALSO section (and the subcommands' pages).
function(make_page page_name command name_text see_also)
  set(include_file "${OUT_DIR}/${page_name}.h2m")
  set(text "[SEE ALSO]\n")
  set(first TRUE)
  foreach(ref IN LISTS see_also)
    string(REGEX REPLACE "^(.*)\\(([0-9])\\)$" "\\1;\\2" ref_parts "${ref}")
    list(GET ref_parts 0 ref_name)
    list(GET ref_parts 1 ref_section)
    string(REPLACE "-" "\\-" ref_name "${ref_name}")
    set(ref_roff "\\fB${ref_name}\\fR(${ref_section})")
    if(first)
      string(APPEND text "${ref_roff}")
      set(first FALSE)
    else()
      string(APPEND text ",\n${ref_roff}")
    endif()
  endforeach()
  string(APPEND text "\n.PP\nThe documentation of shrm is in /usr/share/doc/shrm (docs/*.md).\n")
  file(WRITE "${include_file}" "${text}")
  execute_process(
    COMMAND "${HELP2MAN}" --no-info --no-discard-stderr "--section=${SECTION}"
            "--version-string=${page_name} ${VERSION}" "--name=${name_text}"
            "--source=shrm ${VERSION}" "--include=${include_file}"
            "--output=${page_dir}/${page_name}.${SECTION}" "${command}"
    RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "help2man ${page_name} failed (${rc})")
  endif()
  file(REMOVE "${include_file}")
  execute_process(COMMAND "${GZIP}" -9nf "${page_dir}/${page_name}.${SECTION}" RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "gzip ${page_name}.${SECTION} failed (${rc})")
  endif()
endfunction()

set(see_also_main "")
foreach(sub IN LISTS subcommands)
  list(APPEND see_also_main "${NAME}-${sub}(${SECTION})")
endforeach()
string(REPLACE "," ";" extra "${SEE_ALSO}")
list(APPEND see_also_main ${extra})
make_page("${NAME}" "${PROGRAM}" "${description}" "${see_also_main}")
foreach(sub IN LISTS subcommands)
  make_page("${NAME}-${sub}" "${PROGRAM} ${sub}" "${sub_description_${sub}}"
            "${NAME}(${SECTION})")
endforeach()
