# cmake -DHIL_PROTOCOL_DIR=<dir> -P check_no_8bit_types.cmake
# Fails if any C source or header of the protocol library names an 8-bit exact-width integer type
# (the C28x has no such type: wire octets are hil_octet_t = uint_least8_t, one per element).
file(GLOB sources ${HIL_PROTOCOL_DIR}/*.c ${HIL_PROTOCOL_DIR}/*.h)
list(LENGTH sources count)
if(count LESS 4)
  message(FATAL_ERROR "no protocol sources found in ${HIL_PROTOCOL_DIR}")
endif()
set(bad "")
foreach(path ${sources})
  file(STRINGS ${path} lines REGEX "(^|[^A-Za-z0-9_])u?int8_t")
  if(lines)
    list(APPEND bad "${path}: ${lines}")
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "8-bit exact-width types found:\n${bad}")
endif()
message(STATUS "${count} protocol sources, no 8-bit exact-width types")
