/**
 * @file plant_test_util.h
 * @brief What the plant's C tests share: the two assertion helpers and the Gong / Hou parameter
 * sets (every non-ideality off).
 */
#ifndef PLANT_TEST_UTIL_H
#define PLANT_TEST_UTIL_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "plant.h"

#define T_PI 3.14159265358979323846
#define T_SQRT3 1.7320508075688772935

static int g_checks;
static int g_failures;

static void check_true(int cond, const char *what, int line)
{
    ++g_checks;
    if (!cond) {
        ++g_failures;
        printf("FAIL line %d: %s\n", line, what);
    }
}

static void check_close(double got, double want, double tol, const char *what, int line)
{
    ++g_checks;
    if (!(fabs(got - want) <= tol)) {
        ++g_failures;
        printf("FAIL line %d: %s: got %.17g want %.17g (|diff| %.3g > tol %.3g)\n", line, what,
               got, want, fabs(got - want), tol);
    }
}

#define CHECK(c) check_true((c), #c, __LINE__)
#define CLOSE(got, want, tol) check_close((got), (want), (tol), #got, __LINE__)

/* Gong et al. Table I (SPMSM); t_delay from Table II */
static plant_params_t gong_params(void)
{
    plant_params_t p;
    memset(&p, 0, sizeof p); /* every non-ideality off */
    p.rs_ohm = 0.6383;
    p.ld_h = 2e-3;
    p.lq_h = 2e-3;
    p.psi_f_wb = 0.085;
    p.pole_pairs = 4;
    p.j_kgm2 = 0.013;
    p.b_nms = 0.0035;
    p.v_dc_v = 310.0;
    p.ts_s = 100e-6;
    p.t_delay_s = 34.1e-6;
    p.substeps = 4;
    return p;
}

/* Hou et al. Table 1 (IPMSM), bus and friction as in plant_rt/profiles/hou2021.toml */
static plant_params_t hou_params(void)
{
    plant_params_t p = gong_params();
    p.rs_ohm = 0.78;
    p.ld_h = 2.5e-3;
    p.lq_h = 8.5e-3;
    p.psi_f_wb = 0.303;
    p.pole_pairs = 3;
    p.j_kgm2 = 0.00107;
    p.b_nms = 3e-4;
    p.v_dc_v = 540.0;
    return p;
}

#endif
