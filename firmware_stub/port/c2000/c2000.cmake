# The C2000 (TMS320F28335) port skeleton, compiled on the host against the mock of TI's headers
# (mock/DSP2833x_Device.h, which poisons uint8_t/int8_t: the C28x has no 8-bit type;
# mock/DSP2833x_Examples.h, TI's start-up functions as call counters) with the project's strict
# flags, and tested (tests/c/test_c2000_port.c, tests/test_c2000_port.py): once for each link the
# build can choose (HIL_C2000_LINK, c2000_port.h), main.c's start-up included. Included by the
# top-level CMakeLists.txt.
set(HIL_C2000_PORT ${HIL_ROOT}/firmware_stub/port/c2000)
foreach(link SCI CAN)
  if(link STREQUAL "SCI")
    set(exe test_c2000_port)
  else()
    set(exe test_c2000_port_can)
  endif()
  add_executable(${exe} ${HIL_ROOT}/tests/c/test_c2000_port.c ${HIL_C2000_PORT}/c2000_port.c
                 ${HIL_C2000_PORT}/main.c ${HIL_C2000_PORT}/mock/mock_regs.c)
  target_include_directories(${exe} PRIVATE ${HIL_C2000_PORT} ${HIL_C2000_PORT}/mock)
  target_compile_options(${exe} PRIVATE ${HIL_STRICT_FLAGS})
  target_compile_definitions(${exe} PRIVATE HIL_C2000_LINK=HIL_C2000_LINK_${link})
  target_link_libraries(${exe} PRIVATE hil_fw)
  add_test(NAME c2000_port_${link} COMMAND ${exe})
endforeach()
