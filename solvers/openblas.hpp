// OpenBLAS's own controls, which cblas.h and lapacke.h do not declare: the number of threads its
// routines use (minv runs them on one thread unless a solver's setThreads says otherwise) and
// its build description (for the provenance of result files).
#pragma once

extern "C" {
void openblas_set_num_threads(int threads);
int openblas_get_num_threads();
char* openblas_get_config();
}
