/* The time integrator's residual and Jacobian of a model on one rank, assembled in C: the
 * compiled form kernels (FFCx's tabulate_tensor) called cell by cell, the same sums in the
 * same order as dolfinx's assemblers, and the anchors' rows as cablefem.petsc_utils.
 * RowsAssembler writes them. Python sets the time, the constants and every coefficient but
 * the state (cablefem/native_rows.py); this file copies the state (u, v, a) into the packed
 * coefficients and does the cell loops. It declares the few PETSc functions it calls instead
 * of including PETSc's headers: it is compiled with the C compiler alone and linked against
 * the PETSc library petsc4py uses. PETSC_INT is PETSc's integer (int32_t or int64_t). */

#include <stdint.h>
#include <string.h>

#ifndef PETSC_INT
#define PETSC_INT int32_t
#endif
typedef PETSC_INT PetscInt;
typedef int PetscErrorCode;
typedef void *Vec;
typedef void *Mat;

extern PetscErrorCode VecGetArrayRead(Vec, const double **);
extern PetscErrorCode VecRestoreArrayRead(Vec, const double **);
extern PetscErrorCode VecGetArray(Vec, double **);
extern PetscErrorCode VecRestoreArray(Vec, double **);
extern PetscErrorCode MatZeroEntries(Mat);
extern PetscErrorCode MatSetValuesBlocked(Mat, PetscInt, const PetscInt *, PetscInt,
                                          const PetscInt *, const double *, int);
extern PetscErrorCode MatAssemblyBegin(Mat, int);
extern PetscErrorCode MatAssemblyEnd(Mat, int);
extern PetscErrorCode MatZeroRows(Mat, PetscInt, const PetscInt *, double, Vec, Vec);
extern PetscErrorCode MatMult(Mat, Vec, Vec);
extern PetscErrorCode VecAXPY(Vec, double, Vec);
extern PetscErrorCode KSPSolve(void *, Vec, Vec);
extern PetscErrorCode KSPGetConvergedReason(void *, int *);
extern PetscErrorCode VecCopy(Vec, Vec);
extern PetscErrorCode TSSetI2Function(void *, Vec, void *, void *);
extern PetscErrorCode TSSetI2Jacobian(void *, Mat, Mat, void *, void *);

enum { ADD_VALUES_ = 2, MAT_FINAL_ = 0 };
#ifndef MAX_PARTS /* integrals: given by native_rows.py (its MAX_PARTS, which lays out */
#error "compile with -DMAX_PARTS=n" /* the same struct): one number, one place */
#endif

typedef void (*kernel_t)(double *, const double *, const double *, const double *,
                         const int *, const uint8_t *);

/* One integral of the residual and its Jacobian's: over cells, or over interior facets
 * (a vertex between two elements: both cells' nodes, coordinates and coefficients). */
typedef struct {
    int32_t n, facets;                         /* entities; 1: interior facets */
    int32_t nodes;                             /* nodes an entity's element vector has */
    const int32_t *dofs;                       /* those nodes, entity by entity */
    const double *coords;                      /* each entity's coordinate dofs */
    int32_t coord_stride;
    const int32_t *local;                      /* facets: the two cells' local facets */
    const uint8_t *perms;                      /* facets: their two permutations */
    kernel_t kernel_f, kernel_j[3];            /* the Jacobian: whole, its fast, slow part */
    double *w_f;                               /* the residual's packed coefficients */
    int32_t stride_f, stride_j[3];             /* per entity (facets: both cells') */
    const int32_t *cols_j[3];                  /* each Jacobian's columns of w_f */
    int32_t n_state[3];                        /* u, v, a: how many values each packs */
    const int64_t *pos[3];                     /* where in w_f */
    const int32_t *src[3];                     /* from which entry of the state vector */
} part_t;

/* Filled by native_rows.py; every array is owned by the Python object (kept alive there). */
typedef struct {
    int32_t bs, n_parts;                       /* unknowns per node; parts: cells first */
    part_t parts[MAX_PARTS];
    const double *const_f, *const_j[3];
    int32_t n_bc;                              /* the anchors' dofs x - g */
    const int32_t *bc_dofs;
    const double *g;                           /* the prescribed values' array */
    int32_t n_rows;                            /* the rows weighted by kappa */
    const PetscInt *rows;
    double kappa;
    int32_t n_local;                           /* the vectors' length */
    double *be, *ae, *wj;                      /* work: an entity's vector, matrix, coeffs */
    PetscInt *block_dofs;
    /* the time integrator's callbacks (cablefem_drive): the time Python last brought the
     * coefficients to (NaN: none), Python's calls for a new time and for the Jacobian's
     * decision, and the model's u, v, a (the state of each residual is copied there) */
    double time;
    int (*at)(double);
    int (*decide)(double, double);
    Vec state[3];
    /* the Jacobian's decision taken here, without Python, while the shifts are those of
     * the last whole assembly Python decided (`same`: Python's decision is then always
     * to assemble whole, with no other effect: no reuse, no split); those assemblies */
    int32_t same;
    double shift_v, shift_a;
    int64_t assembled;
} rows_ctx;

#define CHECK(call) do { PetscErrorCode ierr_ = (call); if (ierr_) return (int)ierr_; } while (0)

static int gather(rows_ctx *c, Vec U, Vec V, Vec A) {
    Vec X[3] = {U, V, A};
    for (int s = 0; s < 3; ++s) {
        if (X[s] == NULL)
            continue;
        const double *x;
        CHECK(VecGetArrayRead(X[s], &x));
        for (int32_t p = 0; p < c->n_parts; ++p) {
            part_t *q = &c->parts[p];
            const int64_t *pos = q->pos[s];
            const int32_t *src = q->src[s];
            for (int32_t k = 0; k < q->n_state[s]; ++k)
                q->w_f[pos[k]] = x[src[k]];
        }
        CHECK(VecRestoreArrayRead(X[s], &x));
    }
    return 0;
}

/* The entity loops of dolfinx's assemble_vector (cells, then interior facets) into b (not
 * zeroed here). */
static void add_parts(rows_ctx *c, double *b) {
    const int32_t bs = c->bs;
    for (int32_t p = 0; p < c->n_parts; ++p) {
        const part_t *q = &c->parts[p];
        const int32_t nd = q->nodes * bs;
        for (int32_t i = 0; i < q->n; ++i) {
            memset(c->be, 0, sizeof(double) * nd);
            q->kernel_f(c->be, q->w_f + (int64_t)i * q->stride_f, c->const_f,
                        q->coords + (int64_t)i * q->coord_stride,
                        q->facets ? q->local + 2 * i : NULL,
                        q->facets ? q->perms + 2 * i : NULL);
            const int32_t *dofs = q->dofs + (int64_t)i * q->nodes;
            for (int32_t j = 0; j < q->nodes; ++j)
                for (int32_t k = 0; k < bs; ++k)
                    b[bs * dofs[j] + k] += c->be[bs * j + k];
        }
    }
}

/* The residual with the state U, V, A (V, A may be NULL when the form lacks them) into F:
 * the entities' sum, then the anchors' rows kappa (x - g). */
int cablefem_residual(rows_ctx *c, Vec U, Vec V, Vec A, Vec F) {
    CHECK(gather(c, U, V, A));
    double *b;
    const double *x;
    CHECK(VecGetArray(F, &b));
    memset(b, 0, sizeof(double) * c->n_local);
    add_parts(c, b);
    CHECK(VecGetArrayRead(U, &x));
    for (int32_t i = 0; i < c->n_bc; ++i) { /* dolfinx's set_bc with scale -1 */
        const int32_t d = c->bc_dofs[i];
        b[d] = -1.0 * (c->g[d] - x[d]);
    }
    CHECK(VecRestoreArrayRead(U, &x));
    for (int32_t i = 0; i < c->n_rows; ++i)
        b[c->rows[i]] *= c->kappa;
    CHECK(VecRestoreArray(F, &b));
    return 0;
}

/* The entities' sum alone at the state U, V, A (the anchor forces' residual). */
int cablefem_cells(rows_ctx *c, Vec U, Vec V, Vec A, Vec F) {
    CHECK(gather(c, U, V, A));
    double *b;
    CHECK(VecGetArray(F, &b));
    memset(b, 0, sizeof(double) * c->n_local);
    add_parts(c, b);
    CHECK(VecRestoreArray(F, &b));
    return 0;
}

/* Jacobian `which` (0: whole, 1: its fast part, 2: its slow part) at the state of the last
 * residual into J (zeroed first, its pattern kept) and assembled; with `rows`, then the
 * anchors' rows kappa times identity rows. One rank: the local numbers are the global ones
 * (dolfinx's local-to-global map is then the identity), so no map is applied. */
int cablefem_jacobian(rows_ctx *c, Mat J, int32_t which, int32_t rows) {
    CHECK(MatZeroEntries(J));
    for (int32_t p = 0; p < c->n_parts; ++p) {
        const part_t *q = &c->parts[p];
        const int32_t nd = q->nodes * c->bs;
        if (q->kernel_j[which] == NULL) /* this Jacobian has no integral here */
            continue;
        for (int32_t i = 0; i < q->n; ++i) {
            const double *w = q->w_f + (int64_t)i * q->stride_f;
            const int32_t *cols = q->cols_j[which];
            for (int32_t k = 0; k < q->stride_j[which]; ++k)
                c->wj[k] = w[cols[k]];
            memset(c->ae, 0, sizeof(double) * nd * nd);
            q->kernel_j[which](c->ae, c->wj, c->const_j[which],
                        q->coords + (int64_t)i * q->coord_stride,
                        q->facets ? q->local + 2 * i : NULL,
                        q->facets ? q->perms + 2 * i : NULL);
            const int32_t *dofs = q->dofs + (int64_t)i * q->nodes;
            for (int32_t j = 0; j < q->nodes; ++j)
                c->block_dofs[j] = (PetscInt)dofs[j];
            CHECK(MatSetValuesBlocked(J, q->nodes, c->block_dofs, q->nodes, c->block_dofs,
                                      c->ae, ADD_VALUES_));
        }
    }
    CHECK(MatAssemblyBegin(J, MAT_FINAL_));
    CHECK(MatAssemblyEnd(J, MAT_FINAL_));
    if (rows)
        CHECK(MatZeroRows(J, c->n_rows, c->rows, c->kappa, NULL, NULL));
    return 0;
}

/* The anchor forces' residual at t_{n+1} (cablefem.reactions.AnchorReactions.compute, its
 * dynamic part, the same operations in the same order): with A holding the anchors'
 * prescribed accelerations and zeros elsewhere, R = F(u, v, a_b); the mass solve
 * M da = -R (the anchors' rows zeroed) with the KSP given; A += da; R += M_full da, so that
 * R = F(u, v, a). *reason: the KSP's converged reason (negative: failed, A and R as far as
 * they got). */
int cablefem_forces(rows_ctx *c, void *ksp, Mat M_full, Vec U, Vec V, Vec A, Vec R,
                    Vec rhs, Vec da, Vec Mda, int32_t n_zero, const PetscInt *zero,
                    int *reason) {
    CHECK(cablefem_cells(c, U, V, A, R));
    const double *r;
    double *b;
    CHECK(VecGetArrayRead(R, &r));
    CHECK(VecGetArray(rhs, &b));
    for (int32_t i = 0; i < c->n_local; ++i)
        b[i] = -r[i];
    for (int32_t i = 0; i < n_zero; ++i)
        b[zero[i]] = 0.0;
    CHECK(VecRestoreArray(rhs, &b));
    CHECK(VecRestoreArrayRead(R, &r));
    CHECK(KSPSolve(ksp, rhs, da));
    CHECK(KSPGetConvergedReason(ksp, reason));
    if (*reason < 0)
        return 0;
    CHECK(VecAXPY(A, 1.0, da));
    CHECK(MatMult(M_full, da, Mda));
    CHECK(VecAXPY(R, 1.0, Mda));
    return 0;
}

/* The anchors as AnchorReactions.compute reads them (one rank, three rows a node): the
 * rows of model.a the anchors' accelerations go to (a_rows, from entry a_src of the
 * accelerations (n, 3)), each anchor's first row of the residual, and with virtual hinges
 * (hinges != 0) which anchors have one (mass: the layer's mass, section mass x length). */
typedef struct {
    int32_t n, n_a, hinges;
    const PetscInt *a_rows;
    const int32_t *a_src;
    const PetscInt *row;
    const int32_t *has_hinge;
    const double *mass, *g;
} anchors_t;

/* AnchorReactions.compute's dynamic part on the C route, the same operations in the same
 * order: model.a (A) the anchors' accelerations `acc` (n x 3) and zero elsewhere;
 * cablefem_forces; then each anchor's force -R at its rows, plus, with virtual hinges, its
 * layer's weight and inertia mass (g - acc) (0.0 for an anchor without one), into out
 * (n x 3). */
int cablefem_anchor_forces(rows_ctx *c, const anchors_t *an, const double *acc, double *out,
                           void *ksp, Mat M_full, Vec U, Vec V, Vec A, Vec R, Vec rhs,
                           Vec da, Vec Mda, int32_t n_zero, const PetscInt *zero,
                           int *reason) {
    double *a;
    CHECK(VecGetArray(A, &a));
    memset(a, 0, sizeof(double) * c->n_local);
    for (int32_t j = 0; j < an->n_a; ++j)
        a[an->a_rows[j]] = acc[an->a_src[j]];
    CHECK(VecRestoreArray(A, &a));
    CHECK(cablefem_forces(c, ksp, M_full, U, V, A, R, rhs, da, Mda, n_zero, zero, reason));
    if (*reason < 0)
        return 0;
    const double *r;
    CHECK(VecGetArrayRead(R, &r));
    for (int32_t i = 0; i < an->n; ++i)
        for (int32_t k = 0; k < 3; ++k)
            out[3 * i + k] = -r[an->row[i] + k];
    CHECK(VecRestoreArrayRead(R, &r));
    if (an->hinges)
        for (int32_t i = 0; i < an->n; ++i)
            for (int32_t k = 0; k < 3; ++k)
                out[3 * i + k] += an->has_hinge[i] ? an->mass[i] * (an->g[k] - acc[3 * i + k])
                                                   : 0.0;
    return 0;
}

/* An array watched for changes: its values, and their copy as last seen. */
typedef struct {
    const void *now;
    void *last;
    int64_t nbytes;
} watch_t;

/* Compare each of the n watched arrays with its copy, byte for byte; flags[i] = 1 where
 * they differ (the copy then updated), 0 elsewhere. Returns how many differed. */
int32_t cablefem_changed(const watch_t *w, int32_t n, int32_t *flags) {
    int32_t count = 0;
    for (int32_t i = 0; i < n; ++i) {
        flags[i] = memcmp(w[i].now, w[i].last, (size_t)w[i].nbytes) != 0;
        if (flags[i]) {
            memcpy(w[i].last, w[i].now, (size_t)w[i].nbytes);
            ++count;
        }
    }
    return count;
}

/* The time integrator's residual, as TSSetI2Function calls it: Python brings the time, the
 * constants and the other coefficients to t when t is new (c->at, which sets c->time); the
 * state is copied into the model's u, v, a (as the Python route does: a time law may read
 * them), then cablefem_residual. */
static PetscErrorCode ts_residual(void *ts, double t, Vec U, Vec V, Vec A, Vec F, void *p) {
    rows_ctx *c = p;
    (void)ts;
    if (!(t == c->time))
        CHECK(c->at(t));
    CHECK(VecCopy(U, c->state[0]));
    CHECK(VecCopy(V, c->state[1]));
    CHECK(VecCopy(A, c->state[2]));
    return cablefem_residual(c, U, V, A, F);
}

/* The time integrator's Jacobian, as TSSetI2Jacobian calls it: Python decides (c->decide:
 * negative, an error; 0, J is done: kept, or assembled there; 1, the whole Jacobian is to
 * be assembled here, its constants packed), at the state of the residual just before;
 * with c->same, at the shifts of Python's last whole assembly, without asking. */
static PetscErrorCode ts_jacobian(void *ts, double t, Vec U, Vec V, Vec A, double shift_v,
                                  double shift_a, Mat J, Mat P, void *p) {
    rows_ctx *c = p;
    (void)ts, (void)t, (void)U, (void)V, (void)A, (void)P;
    if (c->same && shift_v == c->shift_v && shift_a == c->shift_a) {
        c->assembled += 1;
        return cablefem_jacobian(c, J, 0, 1);
    }
    const int what = c->decide(shift_v, shift_a);
    if (what < 0)
        return -what;
    if (what != 1)
        return 0;
    c->shift_v = shift_v, c->shift_a = shift_a;
    return cablefem_jacobian(c, J, 0, 1);
}

/* Have the TS call ts_residual and ts_jacobian with this context, into F and J. */
int cablefem_drive(rows_ctx *c, void *ts, Vec F, Mat J) {
    CHECK(TSSetI2Function(ts, F, (void *)ts_residual, c));
    CHECK(TSSetI2Jacobian(ts, J, J, (void *)ts_jacobian, c));
    return 0;
}
