/* A program outside the build tree using the installed library through pkg-config or CMake's
 * find_package: it checks that the headers, the library and the .pc file or CMake package
 * installed by `meson install` work together, and that the library that got loaded is the one
 * the headers describe. */
#include <mlayer/mlayer.h>
#include <stdio.h>
#include <string.h>

int main(void)
{
    if (strcmp(mlr_version_string(), MLR_VERSION_STRING) != 0) {
        fprintf(stderr, "loaded library %s, headers %s\n", mlr_version_string(),
                MLR_VERSION_STRING);
        return 1;
    }
    /* a tiny smoothing problem: 5 samples of a line stay a line */
    double y[5] = {0, 1, 2, 3, 4}, x[5];
    mlr_lgs *lgs = NULL;
    if (mlr_lgs_create(5, 2, 1.0, 1.0, NULL, 5, MLR_LGS_BANDED, NULL, &lgs, NULL) != MLR_OK)
        return 1;
    mlr_status s = mlr_lgs_solve(lgs, y, 1, 1, x, 1, NULL);
    mlr_lgs_destroy(lgs);
    for (int i = 0; i < 5; i++)
        if (s != MLR_OK || x[i] < i - 1e-9 || x[i] > i + 1e-9)
            return 1;
    printf("consumer: mlayer %s OK\n", mlr_version_string());
    return 0;
}
