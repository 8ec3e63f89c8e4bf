# Protocol library and its C tests. Included by the top-level CMakeLists.txt, which defines
# HIL_STRICT_FLAGS and HIL_ROOT (and enables testing).
#
#   hil_protocol           static library: generated message codec (hil_msgs.c) + serial framing
#   test_protocol_vectors  golden vectors (protocol/vectors/) and round-trip checks
set(HIL_PROTOCOL_DIR ${CMAKE_CURRENT_LIST_DIR})

add_library(hil_protocol STATIC
  ${HIL_PROTOCOL_DIR}/hil_msgs.c
  ${HIL_PROTOCOL_DIR}/hil_framing.c)
target_include_directories(hil_protocol PUBLIC ${HIL_PROTOCOL_DIR})
target_compile_options(hil_protocol PRIVATE ${HIL_STRICT_FLAGS})

# The same codec with float intermediate math (-DHIL_MSGS_CALC_FLOAT, for FPUs without double):
# built warning-free and round-trip tested; the golden vectors are the double reference.
add_library(hil_protocol_calc_float STATIC
  ${HIL_PROTOCOL_DIR}/hil_msgs.c
  ${HIL_PROTOCOL_DIR}/hil_framing.c)
target_include_directories(hil_protocol_calc_float PUBLIC ${HIL_PROTOCOL_DIR})
target_compile_options(hil_protocol_calc_float PRIVATE ${HIL_STRICT_FLAGS})
target_compile_definitions(hil_protocol_calc_float PRIVATE HIL_MSGS_CALC_FLOAT)

set(HIL_PROTOCOL_TEST_SOURCES
  ${HIL_ROOT}/tests/c/test_protocol_vectors.c
  ${HIL_ROOT}/tests/c/json_mini.c
  ${HIL_PROTOCOL_DIR}/hil_msgs_reflect.c)

add_executable(test_protocol_vectors ${HIL_PROTOCOL_TEST_SOURCES})
target_link_libraries(test_protocol_vectors PRIVATE hil_protocol)
target_compile_options(test_protocol_vectors PRIVATE ${HIL_STRICT_FLAGS})

add_executable(test_protocol_vectors_calc_float ${HIL_PROTOCOL_TEST_SOURCES})
target_link_libraries(test_protocol_vectors_calc_float PRIVATE hil_protocol_calc_float)
target_compile_options(test_protocol_vectors_calc_float PRIVATE ${HIL_STRICT_FLAGS})
target_compile_definitions(test_protocol_vectors_calc_float PRIVATE HIL_TEST_CALC_FLOAT)

if(UNIX)
  target_link_libraries(test_protocol_vectors PRIVATE m)
  target_link_libraries(test_protocol_vectors_calc_float PRIVATE m)
endif()

add_test(NAME protocol_vectors COMMAND test_protocol_vectors ${HIL_ROOT})
add_test(NAME protocol_roundtrip COMMAND test_protocol_vectors --roundtrip)
add_test(NAME protocol_roundtrip_calc_float COMMAND test_protocol_vectors_calc_float --roundtrip)
# Portable sources must not use 8-bit exact-width integer types (TI C28x has a 16-bit char).
add_test(NAME protocol_no_8bit_types
  COMMAND ${CMAKE_COMMAND} -DHIL_PROTOCOL_DIR=${HIL_PROTOCOL_DIR} -P ${HIL_PROTOCOL_DIR}/check_no_8bit_types.cmake)
