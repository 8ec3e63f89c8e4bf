# Plant core (PMSM dq model + averaged inverter + mechanics + sensors + RK4 system object), C99, double.
# Included by the top-level CMakeLists.txt, which defines HIL_ROOT and HIL_STRICT_FLAGS.
add_library(hil_plant STATIC
  ${HIL_ROOT}/plant_rt/c/pmsm_machine.c
  ${HIL_ROOT}/plant_rt/c/inverter.c
  ${HIL_ROOT}/plant_rt/c/pwm.c
  ${HIL_ROOT}/plant_rt/c/mechanics.c
  ${HIL_ROOT}/plant_rt/c/sensor.c
  ${HIL_ROOT}/plant_rt/c/plant.c
  ${HIL_ROOT}/plant_rt/c/plant_fault.c
)
target_include_directories(hil_plant PUBLIC ${HIL_ROOT}/plant_rt/c)
target_compile_options(hil_plant PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(hil_plant PUBLIC m)

# Unit tests of each part alone and of the assembled plant (no files read: no argv needed).
add_executable(test_plant ${HIL_ROOT}/tests/c/test_plant.c)
target_compile_options(test_plant PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_plant PRIVATE hil_plant)
target_include_directories(test_plant PRIVATE ${HIL_ROOT}/tests/c)
add_test(NAME plant COMMAND test_plant)

# The non-idealities (inverter non-linearity, saturation, ADC/PRNG, friction/load/dyno), each
# part alone and in the assembled plant.
add_executable(test_plant_nonideal ${HIL_ROOT}/tests/c/test_plant_nonideal.c)
target_compile_options(test_plant_nonideal PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_plant_nonideal PRIVATE hil_plant)
target_include_directories(test_plant_nonideal PRIVATE ${HIL_ROOT}/tests/c)
add_test(NAME plant_nonideal COMMAND test_plant_nonideal)

# The cycle engine (host only, POSIX): link I/O, sensor -> SENSE, DUTY validation, plant step,
# reference estimators (the firmware's library) and the recording ring, once per cycle in C; and
# software in the loop, the firmware's SIL port (firmware_stub/port/sil) as its in-process
# controller.
add_library(hil_engine STATIC
  ${HIL_ROOT}/plant_rt/c/engine.c
  ${HIL_ROOT}/plant_rt/c/engine_cycle.c
  ${HIL_ROOT}/plant_rt/c/engine_rx.c
  ${HIL_ROOT}/plant_rt/c/engine_lockstep.c
  ${HIL_ROOT}/plant_rt/c/engine_realtime.c
  ${HIL_ROOT}/plant_rt/c/engine_replay.c
  ${HIL_ROOT}/plant_rt/c/engine_inputs.c
  ${HIL_ROOT}/plant_rt/c/engine_io.c
  ${HIL_ROOT}/plant_rt/c/engine_trace.c
  ${HIL_ROOT}/plant_rt/c/engine_record.c
  ${HIL_ROOT}/plant_rt/c/engine_faults.c
  ${HIL_ROOT}/plant_rt/c/engine_link.c
  ${HIL_ROOT}/plant_rt/c/engine_refs.c
  ${HIL_ROOT}/plant_rt/c/engine_sil.c
  ${HIL_ROOT}/plant_rt/c/live.c
  ${HIL_ROOT}/firmware_stub/port/sil/sil_port.c
  ${HIL_ROOT}/plant_rt/c/rec_ring.c
  ${HIL_ROOT}/plant_rt/c/rec_mcap.c
  ${HIL_ROOT}/plant_rt/c/rec_schema.c
)
target_include_directories(hil_engine PUBLIC ${HIL_ROOT}/plant_rt/c ${HIL_ROOT}/firmware_stub/port/sil)
target_compile_options(hil_engine PRIVATE ${HIL_STRICT_FLAGS} -ffp-contract=off)
target_link_libraries(hil_engine PUBLIC hil_plant hil_fw hil_protocol m)

# The engine alone and in closed loop with the firmware's session (in a thread), under the
# sanitizers in `make sanitize` like every C test.
find_package(Threads REQUIRED)
add_executable(test_engine ${HIL_ROOT}/tests/c/test_engine.c)
target_compile_options(test_engine PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_engine PRIVATE hil_engine Threads::Threads)
target_include_directories(test_engine PRIVATE ${HIL_ROOT}/tests/c)
add_test(NAME engine COMMAND test_engine)
# Run-time faults (plant_fault.h): off = bit for bit, open phase, short, sensors, lock, refusals.
add_executable(test_plant_fault ${HIL_ROOT}/tests/c/test_plant_fault.c)
target_compile_options(test_plant_fault PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_plant_fault PRIVATE hil_plant)
target_include_directories(test_plant_fault PRIVATE ${HIL_ROOT}/tests/c)
add_test(NAME plant_fault COMMAND test_plant_fault)
# The switching mode (pwm.h, inverter.h's switch-level leg, the plant's segment loop).
add_executable(test_plant_switching ${HIL_ROOT}/tests/c/test_plant_switching.c)
target_compile_options(test_plant_switching PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_plant_switching PRIVATE hil_plant)
target_include_directories(test_plant_switching PRIVATE ${HIL_ROOT}/tests/c)
add_test(NAME plant_switching COMMAND test_plant_switching)
