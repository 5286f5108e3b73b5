/* Joint limits: the human range-of-motion table and the anatomical classes of a rig's joints.
 *
 * Source of the ranges (degrees, active range of motion of healthy adults):
 *   American Academy of Orthopaedic Surgeons, "Joint Motion: Method of Measuring and
 *   Recording", AAOS, Chicago 1965 (the averages reprinted in Greene & Heckman, "The Clinical
 *   Measurement of Joint Motion", AAOS 1994):
 *     hip          flexion 120, extension 30, abduction 45, adduction 30, internal 45,
 *                  external rotation 45
 *     knee         flexion 135
 *     ankle        dorsiflexion 20, plantar flexion 50; subtalar inversion 35, eversion 15
 *     first MTP    (toe) flexion 45, extension 70
 *     shoulder     flexion 180, extension 60, abduction 180, internal 70, external rotation 90
 *     elbow        flexion 150; forearm pronation 80, supination 80
 *     wrist        flexion 80, extension 70, radial 20, ulnar deviation 30
 *     cervical     flexion 45, extension 45, lateral bending 45, rotation 60 (each side)
 *     thoracolumbar flexion 80, extension 25, lateral bending 35, rotation 45 (each side)
 *   Clavicle (the shoulder girdle is not in the AAOS table): Ludewig et al., "Motion of the
 *   shoulder complex during multiplanar humeral elevation", J Bone Joint Surg Am 91 (2009)
 *   378-389: clavicle elevation, retraction and posterior rotation of up to about 30 each
 *   during full arm elevation (rounded).
 *
 * The limits model bounds the swing about the joint's centre (the input's mean rotation) and
 * the twist about the bone, both symmetric, so each entry is half the total arc of the joint's
 * largest plane (hip: (120 + 30) / 2 = 75) and half the total axial rotation (hip: 45). The
 * twist about the foot's long axis is inversion/eversion, about the hand's the forearm's
 * pronation/supination (rigs put it on the hand). The spine and the neck share their ranges
 * among their joints. Knees and elbows are hinges (limits.c); their fold bound, 150 degrees,
 * is the AAOS elbow figure and the passive knee flexion (the active knee figure is 135).
 */
#include "guards/limits_internal.h"

#include <ctype.h>
#include <string.h>

#define DEG (3.14159265358979323846 / 180.0)

/* Half-ranges per class: swing, twist (degrees), and whether shared among the class's joints. */
static const struct {
    double swing, twist;
    int shared;
} table[MLR_LIMITS_CLASS_COUNT] = {
    [MLR_LIMITS_CLASS_HIP] = {(120.0 + 30.0) / 2, (45.0 + 45.0) / 2, 0},
    [MLR_LIMITS_CLASS_ANKLE] = {(20.0 + 50.0) / 2, (35.0 + 15.0) / 2, 0},
    [MLR_LIMITS_CLASS_TOE] = {(45.0 + 70.0) / 2, 10.0, 0}, /* toe twist: no figure; small */
    [MLR_LIMITS_CLASS_SHOULDER] = {(180.0 + 60.0) / 2, (70.0 + 90.0) / 2, 0},
    [MLR_LIMITS_CLASS_CLAVICLE] = {30.0, 30.0, 0},
    [MLR_LIMITS_CLASS_WRIST] = {(80.0 + 70.0) / 2, (80.0 + 80.0) / 2, 0},
    [MLR_LIMITS_CLASS_SPINE] = {(80.0 + 25.0) / 2, (45.0 + 45.0) / 2, 1},
    [MLR_LIMITS_CLASS_NECK] = {(45.0 + 45.0) / 2, (60.0 + 60.0) / 2, 1},
};

int limits__table(int cls, size_t n_of_class, double *swing, double *twist)
{
    if (cls < 0 || cls >= MLR_LIMITS_CLASS_COUNT || table[cls].swing == 0.0)
        return 0;
    const double n = table[cls].shared && n_of_class > 1 ? (double)n_of_class : 1.0;
    *swing = table[cls].swing * DEG / n;
    *twist = table[cls].twist * DEG / n;
    return 1;
}

/* Lower-case copy of name into buf (truncated). */
static void lower(const char *name, char *buf, size_t n)
{
    size_t i = 0;
    for (; name && name[i] && i + 1 < n; i++)
        buf[i] = (char)tolower((unsigned char)name[i]);
    buf[i] = 0;
}

int limits__hinge_name(const char *name)
{
    char b[128];
    if (!name)
        return 0;
    lower(name, b, sizeof b);
    if (strstr(b, "knee") || strstr(b, "shin") || strstr(b, "calf") || strstr(b, "lowerleg"))
        return 1;
    if (strstr(b, "elbow") || strstr(b, "forearm") || strstr(b, "lowerarm"))
        return 2;
    if (strstr(b, "leg") && !strstr(b, "up") && !strstr(b, "thigh"))
        return 1;
    return 0;
}

int limits__free_name(const char *name)
{
    char b[128];
    if (!name)
        return 0;
    lower(name, b, sizeof b);
    return !strcmp(b, "hips") || !strcmp(b, "hip") || !strcmp(b, "pelvis") ||
           strstr(b, "root") != NULL;
}

static int name_has(const mlr_rig *rig, size_t j, const char *a, const char *b)
{
    char buf[128];
    if (!rig->names || !rig->names[j])
        return 0;
    lower(rig->names[j], buf, sizeof buf);
    return strstr(buf, a) || (b && strstr(buf, b));
}

void limits__classify(const mlr_rig *rig, const int *is_hinge, const int32_t *main_child, int *cls)
{
    const size_t J = rig->n_joints;
    for (size_t j = 0; j < J; j++)
        cls[j] = MLR_LIMITS_CLASS_OTHER;
    for (size_t j = 0; j < J; j++)
        if (j == 0 || (rig->names && limits__free_name(rig->names[j])))
            cls[j] = MLR_LIMITS_CLASS_FREE;
    for (size_t j = 1; j < J; j++) {
        if (!is_hinge[j])
            continue;
        cls[j] = is_hinge[j] == 1 ? MLR_LIMITS_CLASS_LEG_HINGE : MLR_LIMITS_CLASS_ARM_HINGE;
        const int32_t p = rig->parents[j];
        if (p > 0 && cls[p] == MLR_LIMITS_CLASS_OTHER)
            cls[p] = is_hinge[j] == 1 ? MLR_LIMITS_CLASS_HIP : MLR_LIMITS_CLASS_SHOULDER;
        const int32_t c = main_child[j];
        if (c > 0 && cls[c] == MLR_LIMITS_CLASS_OTHER)
            cls[c] = is_hinge[j] == 1 ? MLR_LIMITS_CLASS_ANKLE : MLR_LIMITS_CLASS_WRIST;
    }
    for (size_t j = 1; j < J; j++) { /* toes: below an ankle; clavicle: above a shoulder */
        const int32_t p = rig->parents[j];
        if (cls[j] == MLR_LIMITS_CLASS_OTHER && p > 0 &&
            (cls[p] == MLR_LIMITS_CLASS_ANKLE || cls[p] == MLR_LIMITS_CLASS_TOE) && !is_hinge[j])
            cls[j] = MLR_LIMITS_CLASS_TOE;
        if (cls[j] == MLR_LIMITS_CLASS_SHOULDER && p > 0 && cls[p] == MLR_LIMITS_CLASS_OTHER &&
            !name_has(rig, (size_t)p, "spine", "chest"))
            cls[p] = MLR_LIMITS_CLASS_CLAVICLE;
    }
    /* spine: ancestors of the clavicles (or shoulders) up to a free joint; neck: named
     * neck/head below a spine joint */
    for (size_t j = 1; j < J; j++) {
        if (cls[j] != MLR_LIMITS_CLASS_CLAVICLE && cls[j] != MLR_LIMITS_CLASS_SHOULDER)
            continue;
        for (int32_t a = rig->parents[j]; a > 0; a = rig->parents[a]) {
            if (cls[a] == MLR_LIMITS_CLASS_FREE)
                break;
            if (cls[a] == MLR_LIMITS_CLASS_OTHER)
                cls[a] = MLR_LIMITS_CLASS_SPINE;
        }
    }
    for (size_t j = 1; j < J; j++) {
        if (cls[j] != MLR_LIMITS_CLASS_OTHER || !name_has(rig, j, "neck", "head"))
            continue;
        for (int32_t a = rig->parents[j]; a > 0; a = rig->parents[a])
            if (cls[a] == MLR_LIMITS_CLASS_SPINE) {
                cls[j] = MLR_LIMITS_CLASS_NECK;
                break;
            }
    }
}
