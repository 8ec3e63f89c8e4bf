/**
 * @file plant_fault_internal.h
 * @brief What plant.c calls in plant_fault.c (not part of the public API). The integration
 * state s starts with (i_d, i_q, omega_m, theta_e) as in plant.c.
 */
#ifndef PLANT_FAULT_INTERNAL_H
#define PLANT_FAULT_INTERNAL_H

#include "plant.h"

/** Every fault off and the settings they replaced restored (called by plant_reset). */
void plant_fault_reset(plant_t *pl);
/** LEG_STUCK: keep the commanded duties, then force the stuck legs (sanitised duties, in place). */
void plant_fault_apply_stuck(plant_t *pl, double duty[3]);
/** Sensor faults on true currents (in place). */
void plant_fault_apply_sensors(const plant_t *pl, double i_abc[3]);
/** Current the sensors see at state s (leg currents: machine + sampled short current) for the
 *  duties in effect. */
void plant_fault_sensed_currents(const plant_t *pl, const double duty[3], const double *s,
                                 double i_abc[3]);
/** Re-evaluate a sample read at t_k under the faults now on (plant_sample). */
void plant_fault_sample(const plant_t *pl, plant_sample_t *out);

/* phase-to-phase short: the network with the leg modes (plant.c's RK4 and event location) */
void plant_short_resolve(plant_t *pl, const double duty[3], double *s, plant_short_mode_t *m);
void plant_short_solve(const plant_t *pl, const plant_short_mode_t *m, const double *s, double sn,
                       double cs, plant_short_out_t *o);
double plant_short_margin(const plant_t *pl, const plant_short_mode_t *m, const double *s);
void plant_short_enforce(const plant_short_mode_t *m, double *s);

#endif
