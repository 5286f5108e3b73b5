/* The cleanup as a job (mlr_cleanup.h: mlr_cleanup_job): the struct's fields checked, then the
 * long-form calls, so that a job gives the same bits as mlr_cleanup_contacts and
 * mlr_cleanup_floor_height. */
#include "guards/cleanup_internal.h"

#include "common/mlr_internal.h"

/* The job itself: not NULL, a reference given whole or not at all, for the motion's frames. */
static mlr_status job_check(const mlr_cleanup_job *job, mlr_diag *diag)
{
    if (!job)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "cleanup job: NULL job");
    const mlr_frames *r = &job->reference;
    const int any = r->root_pos || r->rot || r->trans;
    if (any && r->n_frames != job->motion.n_frames)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "cleanup job: job.reference.n_frames is %zu, not the motion's %zu",
                                r->n_frames, job->motion.n_frames);
    if (!any && r->n_frames != 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "cleanup job: job.reference.n_frames is %zu with no arrays (0 for "
                                "no reference)",
                                r->n_frames);
    return MLR_OK;
}

mlr_status mlr_cleanup_job_validate(const mlr_cleanup_job *job, mlr_diag *diag)
{
    mlr_status st = job_check(job, diag);
    if (st != MLR_OK)
        return st;
    const mlr_frames *m = &job->motion, *r = &job->reference;
    const mlr_cleanup_points *p = &job->points;
    return cleanup__validate(job->rig, m->n_frames, job->fps, job->up, m->root_pos, m->rot,
                             m->trans, r->root_pos, r->rot, r->trans, p->n_points, p->joints,
                             p->end_sites, p->contacts, job->opts, job->n_opts, job->out_root_pos,
                             job->out_rot, diag);
}

mlr_status mlr_cleanup_job_run(const mlr_cleanup_job *job, const mlr_allocator *alloc,
                               mlr_diag *diag)
{
    mlr_status st = job_check(job, diag);
    if (st != MLR_OK)
        return st;
    const mlr_frames *m = &job->motion, *r = &job->reference;
    const mlr_cleanup_points *p = &job->points;
    return mlr_cleanup_contacts(job->rig, m->n_frames, job->fps, job->up, m->root_pos, m->rot,
                                m->trans, r->root_pos, r->rot, r->trans, p->n_points, p->joints,
                                p->end_sites, p->contacts, job->opts, job->n_opts,
                                job->out_root_pos, job->out_rot, job->report, alloc, diag);
}

mlr_status mlr_cleanup_job_floor_height(const mlr_cleanup_job *job, double quantile,
                                        double *height, const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!job)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "floor_height: NULL job");
    const mlr_frames *m = &job->motion;
    const mlr_cleanup_points *p = &job->points;
    return mlr_cleanup_floor_height(job->rig, m->n_frames, m->root_pos, m->rot, m->trans,
                                    p->n_points, p->joints, p->end_sites, p->contacts, job->up,
                                    quantile, height, alloc, diag);
}
