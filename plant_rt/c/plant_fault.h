/**
 * @file plant_fault.h
 * @brief Run-time faults of the plant: electrical (open phase, stuck leg / shorted switch,
 *        phase-to-phase short through a resistance), sensors (current sensor stuck / offset /
 *        gain / dropout, encoder loss / stuck), supply (bus voltage step or sag) and mechanics
 *        (locked rotor, load-torque spike).
 *
 * Each fault is switched on with plant_set_fault() and off with plant_clear_fault() between two
 * plant_step() calls (a cycle engine calls them at period boundaries t_k). With no fault active
 * the plant is bit for bit the plant without this module (tests/test_plant_golden.py,
 * tests/c/test_plant_fault.c). Physics, one fault at a time (plant_rt/README.md "Faults"):
 *
 *   OPEN_PHASE     the phase's wire is disconnected between the inverter leg and the machine
 *                  terminal: the phase current is held at zero by the machine equations
 *                  (pmsm_machine_derivs_open_phase: the other two phases form one circuit),
 *                  whatever the leg does, and the open terminal floats freely (no diode clamps
 *                  it: it is no longer connected to the leg). At the instant the fault is set the
 *                  current of that phase is interrupted: the flux linkage of the remaining loop
 *                  (the line y-z) is continuous, so the new currents keep it (exact also for
 *                  Ld != Lq and with saturation); the magnetic energy released (an arc in a real
 *                  breaker) is booked in plant_energy_t.fault_absorbed_j.
 *   LEG_STUCK      one switch of a leg permanently conducting (shorted switch, or the leg's gate
 *                  drive stuck): level 1 = upper switch, the phase is tied to the + rail;
 *                  level 0 = lower switch, tied to the - rail, for both current directions and
 *                  whatever is commanded (also when the controller disables the leg). The other
 *                  switch of that leg is assumed blocked (a shoot-through would short the stiff
 *                  bus). In the averaged model this is duty 1 / 0 on that leg; with
 *                  inverter_nonlinear the leg keeps the model's treatment of duty 1 / 0 (dead
 *                  time included, as for a commanded duty of 1 / 0: no minimum-pulse model).
 *   PHASE_SHORT    a resistance value (> 0) [ohm] between the machine terminals of phase and
 *                  phase2 (downstream of the current sensors, which measure the leg currents).
 *                  Exact network solution with the leg modes (PWM, stuck, conducting diode, open
 *                  leg): the short current i_f = (u_x - u_y)/R_f is algebraic (no inductance in
 *                  the short), leg currents l_x = i_x + i_f, l_y = i_y - i_f, l_z = i_z; a
 *                  disabled leg's diode conducts on the sign of its LEG current. While both legs
 *                  are driven the machine does not see the short (stiff averaged bus); with the
 *                  legs off the machine brakes into R_f. Needs the ideal inverter
 *                  (inverter_nonlinear = 0: with current-dependent pole voltages the network
 *                  becomes an implicit equation) and no OPEN_PHASE at the same time. Losses
 *                  R_f i_f^2 are booked in short_loss_j (delivered by the inverter:
 *                  dc_bus_in = electrical_in + inverter_loss + short_loss).
 *                  Current sensors sample at t_k, the centre of the zero vector of centre-aligned
 *                  PWM: a PWM leg's terminal is then at the - rail (duty < 1) or the + rail
 *                  (duty = 1), so the SAMPLED short current is the instantaneous one at that
 *                  instant (0 between two PWM legs: a resistive short is invisible to
 *                  zero-vector sampling, as on a real drive, whose desaturation detection is
 *                  not modelled); plant_fault_status() gives the averaged short current.
 *   SENSOR_STUCK   current sensor of `phase` reads `value` [A]
 *   SENSOR_OFFSET  reads true + value [A]
 *   SENSOR_GAIN    reads (1 + value) true (value > -1)
 *   SENSOR_DROPOUT reads 0 A (signal lost: the ADC sees its mid-scale input)
 *                  (one sensor fault per phase; applied to the analog value before the ADC
 *                  model, if on; the ADC's noise deviates are those drawn at t_k, so a sensor
 *                  fault never changes the random stream)
 *   VDC            bus voltage `value` [V] (> 0) instead of the nominal: a sag (set, later
 *                  clear) or a step (set). The bus stays stiff; the whole plant (inverter,
 *                  diode rails, bus ADC) uses the new value from the next period on.
 *   ENCODER_LOSS   the sampled encoder angle is invalid (plant_sample_t.enc_valid = 0, angle 0)
 *   ENCODER_STUCK  the sampled encoder angle stays at its value when the fault was set
 *   LOCKED_ROTOR   the rotor is held at standstill (a mechanical lock, a seized bearing): the
 *                  speed steps to 0 at the next period start and stays there; the lock's
 *                  reaction torque is the snapshot's torque_load_nm and the kinetic energy it
 *                  absorbs is booked in load_work_j (as the dynamometer mode does: the lock is
 *                  the dyno at zero speed).
 *   LOAD_TORQUE    an extra load torque `value` [N m] (positive opposes positive rotation) on
 *                  top of the set torque and the load profile: a torque spike is set, then
 *                  cleared. Acts from the next period on (the load is held per period).
 *
 * Timing. A fault set while the plant is at t_k acts on the dynamics of period k (from t_k on)
 * and on every sample read after it is set (plant_sample() at t_k already shows a sensor,
 * encoder, bus or short fault: the sample is re-evaluated from the state at t_k with the noise
 * deviates drawn at t_k). Second (dual) samples are drawn inside plant_step with the faults
 * active then.
 */
#ifndef PLANT_FAULT_H
#define PLANT_FAULT_H

/** Fault kinds; a fault's bit in plant_faults_active() is 1u << kind. */
typedef enum plant_fault_kind {
    PLANT_FAULT_NONE = 0,
    PLANT_FAULT_OPEN_PHASE = 1,
    PLANT_FAULT_LEG_STUCK = 2,
    PLANT_FAULT_PHASE_SHORT = 3,
    PLANT_FAULT_SENSOR_STUCK = 4,
    PLANT_FAULT_SENSOR_OFFSET = 5,
    PLANT_FAULT_SENSOR_GAIN = 6,
    PLANT_FAULT_SENSOR_DROPOUT = 7,
    PLANT_FAULT_VDC = 8,
    PLANT_FAULT_ENCODER_LOSS = 9,
    PLANT_FAULT_ENCODER_STUCK = 10,
    PLANT_FAULT_LOCKED_ROTOR = 11,
    PLANT_FAULT_LOAD_TORQUE = 12,
    PLANT_FAULT_KIND_COUNT = 13
} plant_fault_kind_t;

/** One fault to switch on. Fields a kind does not use are ignored. */
typedef struct plant_fault {
    int kind;      /**< plant_fault_kind_t */
    int phase;     /**< 0 = a, 1 = b, 2 = c: OPEN_PHASE, LEG_STUCK, PHASE_SHORT, SENSOR_* */
    int phase2;    /**< PHASE_SHORT: the other phase (!= phase) */
    int level;     /**< LEG_STUCK: 1 = upper switch conducts (+ rail), 0 = lower (- rail) */
    double value;  /**< PHASE_SHORT R [ohm] > 0; SENSOR_STUCK [A]; SENSOR_OFFSET [A];
                        SENSOR_GAIN relative error > -1; VDC [V] > 0; LOAD_TORQUE [N m] */
} plant_fault_t;

/** Per-phase current-sensor fault (kind 0 = healthy). */
typedef struct plant_sensor_fault {
    int kind;
    double value;
} plant_sensor_fault_t;

/** Fault state kept in plant_t (private: use the functions below). */
typedef struct plant_fault_state {
    unsigned active;          /* bit 1u << kind for every kind with something on */
    int open_phase;           /* -1 or the disconnected phase */
    int stuck[3];             /* -1, or the level (0/1) the leg is stuck at */
    int short_x, short_y, short_z;  /* PHASE_SHORT phases (z: the third) */
    double short_r_ohm;
    plant_sensor_fault_t sensor[3];
    double v_dc_nominal_v;    /* the bus before VDC was set */
    double enc_hold_rad;      /* ENCODER_STUCK */
    double load_extra_nm;     /* LOAD_TORQUE */
    /* LOCKED_ROTOR: the mechanics settings it replaced */
    int lock_saved_dyno;
    double lock_saved_accel_rad_s2, lock_saved_target_rad_s;
    double absorbed_j;        /* magnetic energy released when a phase current is interrupted */
    unsigned long short_fallbacks; /* steps where no consistent leg mode existed (diagnostic) */
    int short_used;           /* PHASE_SHORT was on since reset (its loss channel is booked) */
    int resample;             /* a sample-related fault changed since the last sampling instant */
    double cmd_prev[3];       /* LEG_STUCK: the duties commanded for the last period */
} plant_fault_state_t;

/** Bit of a kind in plant_fault_state_t.active. */
#define PLANT_FAULT_BIT(kind) (1u << (unsigned)(kind))
/** Kinds that change what the sensors report. */
#define PLANT_FAULT_SENSE_BITS                                                                 \
    (PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT) | PLANT_FAULT_BIT(PLANT_FAULT_SENSOR_STUCK) |     \
     PLANT_FAULT_BIT(PLANT_FAULT_SENSOR_OFFSET) | PLANT_FAULT_BIT(PLANT_FAULT_SENSOR_GAIN) |    \
     PLANT_FAULT_BIT(PLANT_FAULT_SENSOR_DROPOUT))
/** Kinds that change the network topology (the step takes the event-locating path). */
#define PLANT_FAULT_TOPOLOGY_BITS                                                              \
    (PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE) | PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT))

/** Leg modes of the network with a phase-to-phase short (held over one RK4 step). */
typedef struct plant_short_mode {
    int leg[3];             /* inverter_leg_mode_t */
    double u_src_v[3];      /* pole voltages of the source legs (ideal inverter) */
    int open[3];            /* leg k carries no current */
    int constrained;        /* the third phase's current is held at zero */
    int x, y, z;            /* shorted phases, third phase */
    double r_ohm;
} plant_short_mode_t;

/** The network solved at one state. */
typedef struct plant_short_out {
    double did, diq;        /* machine current derivatives [A/s] */
    double v_phase_v[3];    /* machine phase voltages (to the star point) [V] */
    double u_term_v[3];     /* terminal voltages w.r.t. the - rail (all legs open: centred) [V] */
    double i_f_a;           /* short current x -> y [A] */
    double l_a[3];          /* inverter leg currents [A] */
} plant_short_out_t;

/** What the faults do now (plant_fault_status). */
typedef struct plant_fault_status {
    unsigned active;          /**< bitmask 1u << kind */
    double i_short_a;         /**< PHASE_SHORT: averaged-model short current at t (x -> y) [A] */
    double i_leg_a_a, i_leg_b_a, i_leg_c_a; /**< inverter leg currents at t (averaged model) [A] */
    double v_dc_v;            /**< bus voltage in force [V] */
    double absorbed_j;        /**< = plant_energy_t.fault_absorbed_j */
    unsigned long short_fallbacks;
} plant_fault_status_t;

#endif
