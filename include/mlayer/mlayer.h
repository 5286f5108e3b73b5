/* mlayer: smooth motion layers and motion manifolds. Umbrella header of the stable C API. */
#ifndef MLAYER_H
#define MLAYER_H

#include "mlr_version.h"
#include "mlr_common.h"
#include "mlr_band.h"
#include "mlr_lgs.h"
#include "mlr_quat.h"
#include "mlr_motion.h"
#include "mlr_bvh.h"
#include "mlr_fk.h"
#include "mlr_resample.h"
#include "mlr_stream.h"
#include "mlr_layers.h"
#include "mlr_kmeans.h"
#include "mlr_som.h"
#include "mlr_grbf.h"
#include "mlr_markov.h"
#include "mlr_generate.h"
#include "mlr_rig.h"
#include "mlr_contacts.h"
#include "mlr_limits.h"
#include "mlr_ik.h"
#include "mlr_cleanup.h"
#include "mlr_guards.h"
#include "mlr_trim.h"
#include "mlr_mirror.h"
#include "mlr_root_motion.h"
#include "mlr_pipeline.h"
#include "mlr_retarget.h"

#endif /* MLAYER_H */
