/* ndrql.maps._kernels: the compiled kernels of `ndrql plan` and `ndrql astar`, ahead of time, in C99.
 *
 * Each function is a line-for-line port of a numba kernel that stays in the package as the reference
 * (and as the fallback when this extension is not built):
 *
 *   train       ndrql.planning.kernel.train (with rules.step, greedy_action, max_q, greedy_streak,
 *               the rollout, the growing per-episode records and rng's xoshiro256** / splitmix64)
 *   draws       ndrql.planning.kernel._draws (raw generator output, for the tests)
 *   astar8      ndrql.maps.astar_kernel.astar8_kernel
 *   first_blocked, shortcut, supercover
 *               ndrql.maps.lines_kernel._first_blocked, _shortcut, _supercover
 *   bfs4, bottleneck4
 *               ndrql.maps.fields_kernel.bfs4_kernel, bottleneck4_kernel
 *   route_cells ndrql.maps.route_cells.route_cells_numpy (the exact source's drawing; numpy is its reference)
 *   gauss_blur  ndrql.planning.priors.gaussian_blur's numpy loop (scipy's gaussian_filter, bit for bit)
 *   far_field   ndrql.pipeline.sources.exact_distance_field's numpy version (bfs4, then the far cells' values)
 *   snapped     ndrql.planning.priors.snapped_distance's numpy version
 *
 * Results are bit-identical to numba's: the same IEEE double operations in the same order (compile
 * with -ffp-contract=off and without -ffast-math, so no fused multiply-add or reassociation), the same
 * integer wrap-around, the same tie rules. Arrays come in through the buffer protocol (the Python
 * wrappers in ndrql.maps.native and ndrql.planning.compiled hand over C-contiguous numpy arrays of the
 * right dtype) and go out as bytearrays that the wrappers view with numpy, so no numpy headers are
 * needed to build this file.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- buffers */

/* A C-contiguous buffer of `itemsize`-byte items with at least `min_items` items; 0 on success. */
static int get_buffer(PyObject *obj, Py_buffer *view, Py_ssize_t itemsize, Py_ssize_t min_items, int writable,
                      const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) != 0) return -1;
    if (view->itemsize != itemsize || view->len / itemsize < min_items) {
        PyErr_Format(PyExc_ValueError, "%s: expected a C-contiguous buffer of %zd-byte items (at least %zd), got "
                     "%zd-byte items, %zd bytes", name, itemsize, min_items, view->itemsize, view->len);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static PyObject *bytes_of(const void *data, Py_ssize_t nbytes) {
    return PyByteArray_FromStringAndSize((const char *)data, nbytes);
}

/* ---------------------------------------------------------------- the generator (planning.rng) */

static void state_from_seed(uint64_t seed, uint64_t st[4]) {
    uint64_t x = seed;
    for (int i = 0; i < 4; i++) {
        x = x + 0x9E3779B97F4A7C15ULL;
        uint64_t z = x;
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        st[i] = z ^ (z >> 31);
    }
}

static inline uint64_t xoshiro(uint64_t *s0, uint64_t *s1, uint64_t *s2, uint64_t *s3) {
    uint64_t x = *s1 * 5ULL;
    uint64_t result = ((x << 7) | (x >> 57)) * 9ULL;
    uint64_t t = *s1 << 17;
    *s2 ^= *s0;
    *s3 ^= *s1;
    *s1 ^= *s2;
    *s0 ^= *s3;
    *s2 ^= t;
    *s3 = (*s3 << 45) | (*s3 >> 19);
    return result;
}

static PyObject *py_draws(PyObject *self, PyObject *args) {
    long long seed, n;
    if (!PyArg_ParseTuple(args, "LL", &seed, &n)) return NULL;
    if (n < 0) return PyErr_Format(PyExc_ValueError, "n must be >= 0");
    uint64_t st[4];
    state_from_seed((uint64_t)seed, st);
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(n * 8));
    if (!out) return NULL;
    uint64_t *p = (uint64_t *)PyByteArray_AS_STRING(out);
    for (long long i = 0; i < n; i++) p[i] = xoshiro(&st[0], &st[1], &st[2], &st[3]);
    return out;
}

/* ---------------------------------------------------------------- Q-learning (planning.kernel.train) */

enum { MOVE = 0, COLLISION = 1, REVISIT = 2, GOAL = 3 };

/* _SELECT[mask][j]: the j-th set bit of a 4-bit action mask (clamped to the last one; 0 for mask 0). */
static int64_t SELECT[16][4];

static void init_select(void) {
    for (int m = 0; m < 16; m++) {
        int bits[4], k = 0;
        for (int b = 0; b < 4; b++)
            if ((m >> b) & 1) bits[k++] = b;
        for (int j = 0; j < 4; j++) {
            int idx = j < k - 1 ? j : k - 1;
            if (idx < 0) idx = 0;
            SELECT[m][j] = m ? bits[idx] : 0;
        }
    }
}

static inline double max_q(const double *q, int64_t s) {
    double a = q[4 * s], b = q[4 * s + 1], c = q[4 * s + 2], d = q[4 * s + 3];
    double ab = a >= b ? a : b;
    double cd = c >= d ? c : d;
    return ab >= cd ? ab : cd;
}

static inline int64_t greedy_action(const double *q, int64_t s) {
    int64_t best = 0;
    double v = q[4 * s];
    for (int a = 1; a < 4; a++)
        if (q[4 * s + a] > v) {
            v = q[4 * s + a];
            best = a;
        }
    return best;
}

static int64_t rollout(const double *q, const int32_t *nxt, int64_t start, int64_t goal, int32_t *seen, int64_t rmark,
                       int64_t *path, int64_t max_moves) {
    int64_t s = start;
    seen[s] = (int32_t)rmark;
    path[0] = s;
    int64_t n = 0;
    while (n < max_moves) {
        int64_t a = greedy_action(q, s);
        int64_t s2 = nxt[4 * s + a];
        if (s2 == s || (int64_t)seen[s2] == rmark) return -1;
        n += 1;
        path[n] = s2;
        if (s2 == goal) return n;
        seen[s2] = (int32_t)rmark;
        s = s2;
    }
    return -1;
}

static int64_t greedy_streak(int64_t streak, const int64_t *path, int64_t length, const int64_t *best, int64_t best_len) {
    if (length < 0) return 0;
    if (length != best_len) return 1;
    for (int64_t i = 0; i < length + 1; i++)
        if (path[i] != best[i]) return 1;
    return streak + 1;
}

/* The per-episode records, grown by doubling like the numba kernel's (_grown_int/_grown_float/_grown_bool). */
typedef struct {
    int64_t cap;
    int64_t *steps;
    double *returns;
    uint8_t *success;
    int64_t *greedy_len;
} Records;

static int records_resize(Records *r, int64_t cap) {
    int64_t *steps = realloc(r->steps, (size_t)(cap ? cap : 1) * sizeof(int64_t));
    if (steps) r->steps = steps;
    double *returns = realloc(r->returns, (size_t)(cap ? cap : 1) * sizeof(double));
    if (returns) r->returns = returns;
    uint8_t *success = realloc(r->success, (size_t)(cap ? cap : 1));
    if (success) r->success = success;
    int64_t *greedy = realloc(r->greedy_len, (size_t)(cap ? cap : 1) * sizeof(int64_t));
    if (greedy) r->greedy_len = greedy;
    if (!steps || !returns || !success || !greedy) return -1;
    for (int64_t i = r->cap; i < cap; i++) {
        r->steps[i] = 0;
        r->returns[i] = 0.0;
        r->success[i] = 0;
        r->greedy_len[i] = -1;
    }
    r->cap = cap;
    return 0;
}

static void records_free(Records *r) {
    free(r->steps);
    free(r->returns);
    free(r->success);
    free(r->greedy_len);
}

typedef struct {
    const int32_t *nxt;
    int64_t cells, start, goal;
    const double *r_c;
    double *q;
    uint64_t seed;
    double alpha, gamma;
    uint64_t thr;
    int64_t max_steps, max_episodes, window;
    double r_collision, r_goal, r_revisit;
} TrainArgs;

typedef struct {
    int64_t n_done, conv_episode, conv_steps, best_len;
    int64_t *best;
    Records rec;
} TrainOut;

/* The whole run; -1 when out of memory. Runs without the GIL. */
static int train_run(const TrainArgs *A, TrainOut *O) {
    /* what the step loop reads, in locals */
    const int32_t *nxt = A->nxt;
    const double *r_c = A->r_c;
    double *q = A->q;
    const int64_t cells = A->cells, start = A->start, goal = A->goal, max_steps = A->max_steps;
    const uint64_t thr = A->thr;
    const double alpha = A->alpha, gamma = A->gamma;
    const double r_collision = A->r_collision, r_goal = A->r_goal, r_revisit = A->r_revisit;
    uint64_t st[4];
    state_from_seed(A->seed, st);
    uint64_t x0 = st[0], x1 = st[1], x2 = st[2], x3 = st[3];
    int32_t *visited = calloc((size_t)(cells ? cells : 1), sizeof(int32_t));
    int32_t *seen = calloc((size_t)(cells ? cells : 1), sizeof(int32_t));
    int64_t *cur = calloc((size_t)(cells + 1), sizeof(int64_t));
    O->best = calloc((size_t)(cells + 1), sizeof(int64_t));
    memset(&O->rec, 0, sizeof(Records));
    int64_t cap = A->max_episodes < 1024 ? A->max_episodes : 1024;
    int ok = visited && seen && cur && O->best && records_resize(&O->rec, cap) == 0;
    const uint64_t mask32 = 0xFFFFFFFFULL;
    int64_t best_len = -1, streak = 0, total = 0, conv_episode = -1, conv_steps = -1, n_done = 0;
    for (int64_t ep = 0; ok && ep < A->max_episodes; ep++) {
        int64_t mark = ep + 1;
        int64_t s = start;
        visited[s] = (int32_t)mark;
        double ret = 0.0;
        int64_t n = 0;
        int reached = 0;
        while (n < max_steps) {
            uint64_t u = xoshiro(&x0, &x1, &x2, &x3);
            uint64_t lo = u & mask32;
            double m = max_q(q, s);
            const double *qs = q + 4 * s;
            int64_t t0 = qs[0] == m, t1 = qs[1] == m, t2 = qs[2] == m, t3 = qs[3] == m;
            int64_t mask = t0 | (t1 << 1) | (t2 << 2) | (t3 << 3);
            int64_t k = t0 + t1 + t2 + t3;
            if ((u >> 32) < thr) {
                mask = 15;
                k = 4;
            }
            int64_t a;
            if (k == 1) {
                a = t0 ? 0 : (t1 ? 1 : (t2 ? 2 : 3));
            } else {
                int64_t j = (int64_t)((lo * (uint64_t)k) >> 32);
                a = SELECT[mask][j];
            }
            /* rules.step: the precedence is collision, goal, revisit, move */
            int64_t s2 = nxt[4 * s + a];
            int revisit = (int64_t)visited[s2] == mark;
            visited[s2] = (int32_t)mark;
            double r = r_c[s2];
            int outcome = MOVE;
            if (revisit) {
                r = r_revisit;
                outcome = REVISIT;
            }
            if (s2 == goal) {
                r = r_goal;
                outcome = GOAL;
            }
            if (s2 == s) {
                r = r_collision;
                outcome = COLLISION;
            }
            n += 1;
            ret += r;
            if (outcome == GOAL) {
                q[4 * s + a] += alpha * (r - q[4 * s + a]);
                reached = 1;
                break;
            }
            q[4 * s + a] += alpha * (r + gamma * max_q(q, s2) - q[4 * s + a]);
            s = s2;
        }
        if (ep >= cap) {
            cap = 2 * cap < A->max_episodes ? 2 * cap : A->max_episodes;
            if (records_resize(&O->rec, cap) != 0) {
                ok = 0;
                break;
            }
        }
        O->rec.steps[ep] = n;
        O->rec.returns[ep] = ret;
        O->rec.success[ep] = (uint8_t)reached;
        total += n;
        n_done = ep + 1;
        int64_t length = rollout(q, nxt, start, goal, seen, mark, cur, cells);
        O->rec.greedy_len[ep] = length;
        streak = greedy_streak(streak, cur, length, O->best, best_len);
        if (streak == 1) {
            for (int64_t i = 0; i < length + 1; i++) O->best[i] = cur[i];
            best_len = length;
        }
        if (streak >= A->window) {
            conv_episode = ep;
            conv_steps = total;
            break;
        }
    }
    free(visited);
    free(seen);
    free(cur);
    O->n_done = n_done;
    O->conv_episode = conv_episode;
    O->conv_steps = conv_steps;
    O->best_len = best_len;
    return ok ? 0 : -1;
}

static PyObject *py_train(PyObject *self, PyObject *args) {
    PyObject *o_nxt, *o_rc, *o_q;
    long long start, goal, seed, max_steps, max_episodes, window;
    unsigned long long thr;
    double alpha, gamma, r_collision, r_goal, r_revisit;
    if (!PyArg_ParseTuple(args, "OLLOOLddKLLLddd", &o_nxt, &start, &goal, &o_rc, &o_q, &seed, &alpha, &gamma, &thr,
                          &max_steps, &max_episodes, &window, &r_collision, &r_goal, &r_revisit))
        return NULL;
    Py_buffer b_nxt, b_rc, b_q;
    if (get_buffer(o_nxt, &b_nxt, 4, 0, 0, "nxt") != 0) return NULL;
    Py_ssize_t cells = b_nxt.len / 16;
    if (get_buffer(o_rc, &b_rc, 8, cells, 0, "r_c") != 0) {
        PyBuffer_Release(&b_nxt);
        return NULL;
    }
    if (get_buffer(o_q, &b_q, 8, 4 * cells, 1, "q") != 0) {
        PyBuffer_Release(&b_nxt);
        PyBuffer_Release(&b_rc);
        return NULL;
    }
    PyObject *result = NULL;
    if (start < 0 || start >= cells || goal < 0 || goal >= cells) {
        PyErr_Format(PyExc_IndexError, "start %lld or goal %lld is not a cell of %zd", start, goal, cells);
    } else {
        TrainArgs A = {(const int32_t *)b_nxt.buf, cells, start, goal, (const double *)b_rc.buf, (double *)b_q.buf,
                       (uint64_t)seed, alpha, gamma, (uint64_t)thr, max_steps, max_episodes < 0 ? 0 : max_episodes,
                       window, r_collision, r_goal, r_revisit};
        TrainOut O;
        int rc;
        Py_BEGIN_ALLOW_THREADS
        rc = train_run(&A, &O);
        Py_END_ALLOW_THREADS
        if (rc != 0) {
            PyErr_NoMemory();
        } else {
            Py_ssize_t cap = (Py_ssize_t)O.rec.cap;
            result = Py_BuildValue("LNNNNLLLN", (long long)O.n_done, bytes_of(O.rec.steps, cap * 8),
                                   bytes_of(O.rec.returns, cap * 8), bytes_of(O.rec.success, cap),
                                   bytes_of(O.rec.greedy_len, cap * 8), (long long)O.conv_episode,
                                   (long long)O.conv_steps, (long long)O.best_len,
                                   bytes_of(O.best, (Py_ssize_t)(cells + 1) * 8));
        }
        records_free(&O.rec);
        free(O.best);
    }
    PyBuffer_Release(&b_nxt);
    PyBuffer_Release(&b_rc);
    PyBuffer_Release(&b_q);
    return result;
}

/* ---------------------------------------------------------------- 8-connected A* (maps.astar_kernel) */

#define SQRT2 1.4142135623730951
static const int64_t DR[8] = {-1, 1, 0, 0, -1, -1, 1, 1};
static const int64_t DC[8] = {0, 0, -1, 1, -1, 1, -1, 1};
static const double STEP[8] = {1.0, 1.0, 1.0, 1.0, SQRT2, SQRT2, SQRT2, SQRT2};

/* The open list: a binary heap of (f, insertion count) keys, one 32-byte entry per push (the entries together, and
 * sifted by moving a hole, not by swaps). The order is total (counts are unique), so any correct heap pops the same
 * entries in the same order as numba's. */
typedef struct {
    double f, g;
    int64_t cnt, node;
} Entry;

typedef struct {
    Entry *e;
    int64_t cap;
} Heap;

static inline int entry_less(const Entry *a, const Entry *b) {
    return a->f < b->f || (a->f == b->f && a->cnt < b->cnt);
}

/* Puts `x` at slot i (the new last slot) and moves it up. */
static void sift_up(Heap *h, int64_t i, Entry x) {
    Entry *e = h->e;
    while (i > 0) {
        int64_t parent = (i - 1) >> 1;
        if (!entry_less(&x, &e[parent])) break;
        e[i] = e[parent];
        i = parent;
    }
    e[i] = x;
}

/* Moves the last entry (slot `size`, already out of the heap) down from the root. */
static void sift_down(Heap *h, int64_t size) {
    Entry *e = h->e;
    Entry x = e[size];
    int64_t i = 0;
    for (;;) {
        int64_t left = 2 * i + 1;
        if (left >= size) break;
        int64_t child = left;
        if (left + 1 < size && entry_less(&e[left + 1], &e[left])) child = left + 1;
        if (!entry_less(&e[child], &x)) break;
        e[i] = e[child];
        i = child;
    }
    e[i] = x;
}

static int heap_grow(Heap *h) {
    int64_t cap = 2 * h->cap;
    Entry *e = realloc(h->e, (size_t)cap * sizeof(Entry));
    if (!e) return -1;
    h->e = e;
    h->cap = cap;
    return 0;
}

static inline int64_t imin(int64_t a, int64_t b) { return b < a ? b : a; }
static inline int64_t imax(int64_t a, int64_t b) { return b > a ? b : a; }
static inline int64_t iabs(int64_t a) { return a < 0 ? -a : a; }

/* 0: found (path in *path_out, length *len_out), 1: unreachable, -1: out of memory. Runs without the GIL. */
static int astar8_run(const uint8_t *flat, int64_t h, int64_t w, int64_t s_idx, int64_t g_idx, int corner_cutting,
                      int64_t **path_out, int64_t *len_out, double *cost_out, int64_t *expanded_out) {
    int64_t n = h * w;
    double *best = malloc((size_t)(n ? n : 1) * sizeof(double));
    int64_t *parent = malloc((size_t)(n ? n : 1) * sizeof(int64_t));
    uint8_t *closed = calloc((size_t)(n ? n : 1), 1);
    Heap hp = {malloc(1024 * sizeof(Entry)), 1024};
    int status = -1;
    int64_t expanded = 0;
    if (!best || !parent || !closed || !hp.e) goto done;
    for (int64_t i = 0; i < n; i++) {
        best[i] = INFINITY;
        parent[i] = -1;
    }
    int64_t gr = g_idx / w, gc = g_idx % w, sr = s_idx / w, sc = s_idx % w;
    int64_t dh = iabs(sr - gr), dw = iabs(sc - gc);
    hp.e[0].f = (SQRT2 - 1.0) * (double)imin(dh, dw) + (double)imax(dh, dw);
    hp.e[0].cnt = 0;
    hp.e[0].g = 0.0;
    hp.e[0].node = s_idx;
    int64_t size = 1, counter = 0;
    best[s_idx] = 0.0;
    status = 1;
    while (size > 0) {
        double gcost = hp.e[0].g;
        int64_t idx = hp.e[0].node;
        size -= 1;
        if (size > 0) sift_down(&hp, size);
        if (closed[idx]) continue;
        closed[idx] = 1;
        expanded += 1;
        if (idx == g_idx) {
            int64_t length = 0;
            for (int64_t k = idx; k >= 0; k = parent[k]) length += 1;
            int64_t *path = malloc((size_t)length * sizeof(int64_t));
            if (!path) {
                status = -1;
                goto done;
            }
            int64_t k = idx;
            for (int64_t i = length - 1; i >= 0; i--) {
                path[i] = k;
                k = parent[k];
            }
            *path_out = path;
            *len_out = length;
            *cost_out = gcost;
            status = 0;
            goto done;
        }
        int64_t r = idx / w, c = idx % w;
        for (int m = 0; m < 8; m++) {
            int64_t dr = DR[m], dc = DC[m];
            int64_t nr = r + dr, nc = c + dc;
            if (nr < 0 || nr >= h || nc < 0 || nc >= w) continue;
            int64_t nidx = nr * w + nc;
            if (flat[nidx] || closed[nidx]) continue;
            if (dr != 0 && dc != 0 && !corner_cutting && (flat[nr * w + c] || flat[r * w + nc])) continue;
            double ng = gcost + STEP[m];
            if (ng < best[nidx] - 1e-12) {
                best[nidx] = ng;
                parent[nidx] = idx;
                counter += 1;
                if (size == hp.cap && heap_grow(&hp) != 0) {
                    status = -1;
                    goto done;
                }
                dh = iabs(nr - gr);
                dw = iabs(nc - gc);
                Entry x = {ng + (SQRT2 - 1.0) * (double)imin(dh, dw) + (double)imax(dh, dw), ng, counter, nidx};
                sift_up(&hp, size, x);
                size += 1;
            }
        }
    }
    *cost_out = INFINITY;
done:
    *expanded_out = expanded;
    free(best);
    free(parent);
    free(closed);
    free(hp.e);
    return status;
}

static PyObject *py_astar8(PyObject *self, PyObject *args) {
    PyObject *o_blocked;
    long long h, w, s_idx, g_idx;
    int corner_cutting;
    if (!PyArg_ParseTuple(args, "OLLLLp", &o_blocked, &h, &w, &s_idx, &g_idx, &corner_cutting)) return NULL;
    if (h < 0 || w < 1 || s_idx < 0 || s_idx >= h * w || g_idx < 0 || g_idx >= h * w)
        return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld or cells %lld, %lld", h, w, s_idx, g_idx);
    Py_buffer b;
    if (get_buffer(o_blocked, &b, 1, (Py_ssize_t)(h * w), 0, "blocked") != 0) return NULL;
    int64_t *path = NULL, length = 0, expanded = 0;
    double cost = INFINITY;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = astar8_run((const uint8_t *)b.buf, h, w, s_idx, g_idx, corner_cutting, &path, &length, &cost, &expanded);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&b);
    if (status < 0) return PyErr_NoMemory();
    PyObject *out = Py_BuildValue("NdL", bytes_of(path, (Py_ssize_t)length * 8), cost, (long long)expanded);
    free(path);
    return out;
}

/* ---------------------------------------------------------------- segments (maps.lines_kernel) */

#define EPS 1e-9

/* Python's (and numba's) min and max of two floats: the first argument unless the second is strictly smaller/larger. */
static inline double fmin_py(double a, double b) { return b < a ? b : a; }
static inline double fmax_py(double a, double b) { return b > a ? b : a; }

static inline double col_at(double r0, double c0, double r1, double c1, double y) {
    if (y == r0) return c0;
    if (y == r1) return c1;
    return c0 + (y - r0) * (c1 - c0) / (r1 - r0);
}

static inline void row_span(double r0, double c0, double r1, double c1, int64_t r, int64_t *lo, int64_t *hi) {
    double y_lo = fmax_py(fmin_py(r0, r1), (double)r - 0.5 - EPS);
    double y_hi = fmin_py(fmax_py(r0, r1), (double)r + 0.5 + EPS);
    if (y_lo > y_hi) {
        *lo = 1;
        *hi = 0;
        return;
    }
    double a, b;
    if (r1 == r0) {
        a = c0;
        b = c1;
    } else if (r0 < r1) {
        a = col_at(r0, c0, r1, c1, y_lo);
        b = col_at(r0, c0, r1, c1, y_hi);
    } else {
        a = col_at(r1, c1, r0, c0, y_lo);
        b = col_at(r1, c1, r0, c0, y_hi);
    }
    double c_lo = fmin_py(a, b), c_hi = fmax_py(a, b);
    *lo = (int64_t)ceil(c_lo - 0.5 - EPS);
    *hi = (int64_t)floor(c_hi + 0.5 + EPS);
}

static inline void row_range(double r0, double r1, int64_t *first, int64_t *last, int64_t *step) {
    int64_t lo = (int64_t)ceil(fmin_py(r0, r1) - 0.5 - EPS);
    int64_t hi = (int64_t)floor(fmax_py(r0, r1) + 0.5 + EPS);
    if (r1 >= r0) {
        *first = lo;
        *last = hi;
        *step = 1;
    } else {
        *first = hi;
        *last = lo;
        *step = -1;
    }
}

static int first_blocked(const uint8_t *obst, int64_t h, int64_t w, double r0, double c0, double r1, double c1,
                         int64_t *br, int64_t *bc) {
    int64_t first, last, step;
    row_range(r0, r1, &first, &last, &step);
    int64_t r = first;
    for (;;) {
        int64_t lo, hi;
        row_span(r0, c0, r1, c1, r, &lo, &hi);
        if (hi >= lo) {
            int64_t c, c_end, c_step;
            if (c1 >= c0) {
                c = lo; c_end = hi; c_step = 1;
            } else {
                c = hi; c_end = lo; c_step = -1;
            }
            for (;;) {
                if (r < 0 || r >= h || c < 0 || c >= w || obst[r * w + c]) {
                    *br = r;
                    *bc = c;
                    return 1;
                }
                if (c == c_end) break;
                c += c_step;
            }
        }
        if (r == last) break;
        r += step;
    }
    *br = 0;
    *bc = 0;
    return 0;
}

static PyObject *py_first_blocked(PyObject *self, PyObject *args) {
    PyObject *o;
    long long h, w;
    double r0, c0, r1, c1;
    if (!PyArg_ParseTuple(args, "OLLdddd", &o, &h, &w, &r0, &c0, &r1, &c1)) return NULL;
    Py_buffer b;
    if (get_buffer(o, &b, 1, (Py_ssize_t)(h * w), 0, "obstacles") != 0) return NULL;
    int64_t br, bc;
    int found = first_blocked((const uint8_t *)b.buf, h, w, r0, c0, r1, c1, &br, &bc);
    PyBuffer_Release(&b);
    return Py_BuildValue("NLL", PyBool_FromLong(found), (long long)br, (long long)bc);
}

static PyObject *py_shortcut(PyObject *self, PyObject *args) {
    PyObject *o, *o_pts;
    long long h, w;
    if (!PyArg_ParseTuple(args, "OLLO", &o, &h, &w, &o_pts)) return NULL;
    Py_buffer b, bp;
    if (get_buffer(o, &b, 1, (Py_ssize_t)(h * w), 0, "obstacles") != 0) return NULL;
    if (get_buffer(o_pts, &bp, 8, 0, 0, "pts") != 0) {
        PyBuffer_Release(&b);
        return NULL;
    }
    const uint8_t *obst = (const uint8_t *)b.buf;
    const double *pts = (const double *)bp.buf;
    int64_t n = bp.len / 16;
    int64_t *keep = malloc((size_t)(n ? n : 1) * sizeof(int64_t));
    PyObject *out = NULL;
    if (!keep) {
        PyErr_NoMemory();
    } else {
        int64_t m = 0, i = 0;
        if (n > 0) keep[m++] = 0;
        Py_BEGIN_ALLOW_THREADS
        while (i < n - 1) {
            int64_t nxt = i + 1;
            for (int64_t j = n - 1; j > i + 1; j--) {
                int64_t br, bc;
                if (!first_blocked(obst, h, w, pts[2 * i], pts[2 * i + 1], pts[2 * j], pts[2 * j + 1], &br, &bc)) {
                    nxt = j;
                    break;
                }
            }
            keep[m++] = nxt;
            i = nxt;
        }
        Py_END_ALLOW_THREADS
        out = bytes_of(keep, (Py_ssize_t)m * 8);
        free(keep);
    }
    PyBuffer_Release(&b);
    PyBuffer_Release(&bp);
    return out;
}

static PyObject *py_supercover(PyObject *self, PyObject *args) {
    double r0, c0, r1, c1;
    if (!PyArg_ParseTuple(args, "dddd", &r0, &c0, &r1, &c1)) return NULL;
    int64_t first, last, step, lo, hi, count = 0;
    row_range(r0, r1, &first, &last, &step);
    for (int64_t r = first;; r += step) {
        row_span(r0, c0, r1, c1, r, &lo, &hi);
        if (hi >= lo) count += hi - lo + 1;
        if (r == last) break;
    }
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(count * 16));
    if (!out) return NULL;
    int64_t *p = (int64_t *)PyByteArray_AS_STRING(out);
    int64_t k = 0;
    for (int64_t r = first;; r += step) {
        row_span(r0, c0, r1, c1, r, &lo, &hi);
        if (c1 >= c0) {
            for (int64_t c = lo; c < hi + 1; c++) {
                p[2 * k] = r;
                p[2 * k + 1] = c;
                k++;
            }
        } else {
            for (int64_t c = hi; c > lo - 1; c--) {
                p[2 * k] = r;
                p[2 * k + 1] = c;
                k++;
            }
        }
        if (r == last) break;
    }
    return out;
}

/* ---------------------------------------------------------------- grid fields (maps.fields_kernel) */

static const int64_t DR4[4] = {-1, 1, 0, 0};
static const int64_t DC4[4] = {0, 0, -1, 1};

/* 4-connected move counts from `src` into dist (n int64), -1 where unreachable or blocked; 0, or -1 out of memory. */
static int bfs4_run(const uint8_t *blocked, int64_t h, int64_t w, int64_t src, int64_t *dist) {
    int64_t n = h * w;
    for (int64_t i = 0; i < n; i++) dist[i] = -1;
    if (blocked[src]) return 0;
    int32_t *queue = malloc((size_t)(n ? n : 1) * 2 * sizeof(int32_t)); /* (row, col) pairs: no division per cell */
    if (!queue) return -1;
    int64_t head = 0, tail = 0;
    dist[src] = 0;
    queue[0] = (int32_t)(src / w);
    queue[1] = (int32_t)(src % w);
    tail = 1;
    while (head < tail) {
        int64_t r = queue[2 * head], c = queue[2 * head + 1];
        head++;
        int64_t d = dist[r * w + c] + 1;
        for (int m = 0; m < 4; m++) {
            int64_t nr = r + DR4[m], nc = c + DC4[m];
            if (nr < 0 || nr >= h || nc < 0 || nc >= w) continue;
            int64_t nidx = nr * w + nc;
            if (dist[nidx] < 0 && !blocked[nidx]) {
                dist[nidx] = d;
                queue[2 * tail] = (int32_t)nr;
                queue[2 * tail + 1] = (int32_t)nc;
                tail++;
            }
        }
    }
    free(queue);
    return 0;
}

static PyObject *py_bfs4(PyObject *self, PyObject *args) {
    PyObject *o_blocked;
    long long h, w, src;
    if (!PyArg_ParseTuple(args, "OLLL", &o_blocked, &h, &w, &src)) return NULL;
    if (h < 1 || w < 1 || h > INT32_MAX || w > INT32_MAX || src < 0 || src >= h * w) /* rows, cols fit the queue's int32 */
        return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld or source cell %lld", h, w, src);
    Py_buffer b;
    if (get_buffer(o_blocked, &b, 1, (Py_ssize_t)(h * w), 0, "blocked") != 0) return NULL;
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(h * w * 8));
    if (!out) {
        PyBuffer_Release(&b);
        return NULL;
    }
    int64_t *dist = (int64_t *)PyByteArray_AS_STRING(out);
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = bfs4_run((const uint8_t *)b.buf, h, w, src, dist);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&b);
    if (status < 0) {
        Py_DECREF(out);
        return PyErr_NoMemory();
    }
    return out;
}

/* A max-heap of (key, node) for the widest-path search; ties in any order (only the keys are returned). */
typedef struct {
    double *key;
    int64_t *node;
    int64_t size, cap;
} MaxHeap;

static int maxheap_push(MaxHeap *hp, double key, int64_t node) {
    if (hp->size == hp->cap) {
        int64_t cap = 2 * hp->cap;
        double *k = realloc(hp->key, (size_t)cap * sizeof(double));
        if (k) hp->key = k;
        int64_t *nd = realloc(hp->node, (size_t)cap * sizeof(int64_t));
        if (nd) hp->node = nd;
        if (!k || !nd) return -1;
        hp->cap = cap;
    }
    int64_t i = hp->size++;
    while (i > 0) {
        int64_t parent = (i - 1) >> 1;
        if (!(hp->key[parent] < key)) break;
        hp->key[i] = hp->key[parent];
        hp->node[i] = hp->node[parent];
        i = parent;
    }
    hp->key[i] = key;
    hp->node[i] = node;
    return 0;
}

static void maxheap_pop(MaxHeap *hp) {
    double key = hp->key[--hp->size];
    int64_t node = hp->node[hp->size], size = hp->size, i = 0;
    for (;;) {
        int64_t child = 2 * i + 1;
        if (child >= size) break;
        if (child + 1 < size && hp->key[child] < hp->key[child + 1]) child += 1;
        if (!(key < hp->key[child])) break;
        hp->key[i] = hp->key[child];
        hp->node[i] = hp->node[child];
        i = child;
    }
    if (size > 0) {
        hp->key[i] = key;
        hp->node[i] = node;
    }
}

/* The widest path (maxi-min Dijkstra): the largest, over 4-connected paths through free cells from `s` to `g`, of
 * the smallest value on the path (both ends included); -inf when an end is blocked or NaN or they are not
 * connected. NaN cells count as blocked. *out gets it; 0, or -1 out of memory. Runs without the GIL. */
static int bottleneck4_run(const double *values, const uint8_t *blocked, int64_t h, int64_t w, int64_t s, int64_t g,
                           double *out) {
    int64_t n = h * w;
    *out = -INFINITY;
    if (blocked[s] || blocked[g] || values[s] != values[s] || values[g] != values[g]) return 0;
    double *best = malloc((size_t)n * sizeof(double));
    uint8_t *closed = calloc((size_t)n, 1);
    MaxHeap hp = {malloc(1024 * sizeof(double)), malloc(1024 * sizeof(int64_t)), 0, 1024};
    int status = -1;
    if (!best || !closed || !hp.key || !hp.node) goto done;
    for (int64_t i = 0; i < n; i++) best[i] = -INFINITY;
    best[s] = values[s];
    if (maxheap_push(&hp, values[s], s) != 0) goto done;
    status = 0;
    while (hp.size > 0) {
        double key = hp.key[0];
        int64_t idx = hp.node[0];
        maxheap_pop(&hp);
        if (closed[idx]) continue;
        closed[idx] = 1;
        if (idx == g) {
            *out = key;
            break;
        }
        int64_t r = idx / w, c = idx % w;
        for (int m = 0; m < 4; m++) {
            int64_t nr = r + DR4[m], nc = c + DC4[m];
            if (nr < 0 || nr >= h || nc < 0 || nc >= w) continue;
            int64_t nidx = nr * w + nc;
            double v = values[nidx];
            if (closed[nidx] || blocked[nidx] || v != v) continue;
            double k = v < key ? v : key;
            if (k > best[nidx]) {
                best[nidx] = k;
                if (maxheap_push(&hp, k, nidx) != 0) {
                    status = -1;
                    goto done;
                }
            }
        }
    }
done:
    free(best);
    free(closed);
    free(hp.key);
    free(hp.node);
    return status;
}

static PyObject *py_bottleneck4(PyObject *self, PyObject *args) {
    PyObject *o_values, *o_blocked;
    long long h, w, s, g;
    if (!PyArg_ParseTuple(args, "OOLLLL", &o_values, &o_blocked, &h, &w, &s, &g)) return NULL;
    if (h < 1 || w < 1 || s < 0 || s >= h * w || g < 0 || g >= h * w)
        return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld or cells %lld, %lld", h, w, s, g);
    Py_buffer bv, bb;
    if (get_buffer(o_values, &bv, 8, (Py_ssize_t)(h * w), 0, "values") != 0) return NULL;
    if (get_buffer(o_blocked, &bb, 1, (Py_ssize_t)(h * w), 0, "blocked") != 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    double out;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = bottleneck4_run((const double *)bv.buf, (const uint8_t *)bb.buf, h, w, s, g, &out);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bv);
    PyBuffer_Release(&bb);
    if (status < 0) return PyErr_NoMemory();
    return PyFloat_FromDouble(out);
}

/* ---------------------------------------------------------------- the exact source's drawing (maps.route_cells) */

/* GCC vectorizes the byte loops below only when asked at -O2 (no floating point in them: the results cannot differ). */
#if defined(__GNUC__) && !defined(__clang__)
#define VECTORIZE __attribute__((optimize("tree-vectorize")))
#else
#define VECTORIZE
#endif

/* Adds each `px`-pixel block of a line of pixel counts (pixels x0 .. x0 + n - 1 of an image row, x0 and n multiples
 * of px) to its cell, then clears the line. */
VECTORIZE static void flush_blocks(uint16_t *line, int64_t x0, int64_t n, int64_t px, int64_t *cells) {
    for (int64_t x = 0; x < n; x += px) {
        int64_t sum = 0;
        for (int64_t i = x; i < x + px; i++) sum += line[i];
        cells[(x0 + x) / px] += sum;
    }
    memset(line, 0, (size_t)n * sizeof(uint16_t));
}

/* floor(v) as an integer, for |v| < 2^53 (what numpy's floor then astype(int64) gives). */
static inline int64_t floor_int(double v) {
    int64_t t = (int64_t)v;
    return t - ((double)t > v);
}

/* The route of sources.drawn_priors at pixel level: the samples of each waypoint segment (numpy.linspace's
 * values: i * (1 / (n - 1)), the last exactly 1), a `guide_px` square stamped at floor(p - half) of each (clipped
 * to the image), the region every pixel with a stamped pixel from `before` before it to `after` after it in both
 * axes, then per cell of `px` x `px` pixels the share of region and guide pixels. Works inside the guide's bounding
 * box widened by the window (to whole cells): along the rows by ORs of each row with itself shifted by 1, 2, 4, ...,
 * down the columns by a sliding count of rows, a cell row's pixel counts summed per column before they are added
 * per cell; 0, or -1 out of memory. */
VECTORIZE static int route_cells_run(const double *wp, int64_t k, const int64_t *counts, int64_t rows, int64_t cols,
                                     int64_t px, int64_t guide_px, double half, int64_t before, int64_t after,
                                     double *region, double *guide) {
    int64_t h = rows * px, w = cols * px, ncell = rows * cols;
    for (int64_t i = 0; i < ncell; i++) region[i] = guide[i] = 0.0;
    if (k < 1) return 0;
    int64_t total = 1;
    for (int64_t j = 0; j + 1 < k; j++) total += counts[j];
    int64_t *top = malloc((size_t)total * 2 * sizeof(int64_t));
    if (!top) return -1;
    top[0] = floor_int(wp[0] - half);
    top[1] = floor_int(wp[1] - half);
    int64_t m = 1;
    for (int64_t j = 0; j + 1 < k; j++) {
        const double *a = wp + 2 * j, *b = wp + 2 * j + 2;
        double d0 = b[0] - a[0], d1 = b[1] - a[1];
        int64_t n = counts[j];
        double step = n > 1 ? 1.0 / (double)(n - 1) : 0.0;
        for (int64_t i = 0; i < n; i++) {
            double t = n > 1 ? (i == n - 1 ? 1.0 : (double)i * step + 0.0) : 0.0;
            top[2 * m] = floor_int((a[0] + d0 * t) - half);
            top[2 * m + 1] = floor_int((a[1] + d1 * t) - half);
            m++;
        }
    }
    int64_t r0 = h, r1 = -1, c0 = w, c1 = -1; /* the stamped pixels' bounding box (after clipping) */
    for (int64_t i = 0; i < m; i++) {
        for (int64_t d = 0; d < guide_px; d += guide_px - 1 > 0 ? guide_px - 1 : 1) { /* the square's corners */
            int64_t r = top[2 * i] + d, c = top[2 * i + 1] + d;
            r = r < 0 ? 0 : (r > h - 1 ? h - 1 : r);
            c = c < 0 ? 0 : (c > w - 1 ? w - 1 : c);
            if (r < r0) r0 = r;
            if (r > r1) r1 = r;
            if (c < c0) c0 = c;
            if (c > c1) c1 = c;
        }
    }
    int64_t win = before + after + 1;
    int64_t y0 = r0 - after > 0 ? r0 - after : 0, y1 = r1 + before < h - 1 ? r1 + before : h - 1;
    int64_t x0 = c0 - after > 0 ? c0 - after : 0, x1 = c1 + before < w - 1 ? c1 + before : w - 1;
    x0 = x0 / px * px; /* whole cells */
    x1 = (x1 / px + 1) * px - 1;
    int64_t gh = r1 - r0 + 1, vw = x1 - x0 + 1, sw = vw + win; /* sw: a row padded for the window */
    /* g: the guide rows r0..r1 on columns x0 - before .. x1 + after (zero outside the image and the box), dilated
     * along the rows in place (g[x] then covers columns x0 + x - before .. x0 + x + after: column x0 + x's window) */
    uint8_t *g = calloc((size_t)(gh * sw), 1), *tmp = malloc((size_t)sw);
    uint16_t *cnt = calloc((size_t)vw, sizeof(uint16_t)), *band = calloc((size_t)vw, sizeof(uint16_t));
    int64_t *cells = calloc((size_t)ncell, sizeof(int64_t));
    int status = -1;
    if (!g || !tmp || !cnt || !band || !cells) goto done;
    for (int64_t i = 0; i < m; i++) {
        for (int64_t dr = 0; dr < guide_px; dr++) {
            int64_t r = top[2 * i] + dr;
            r = r < 0 ? 0 : (r > h - 1 ? h - 1 : r);
            for (int64_t dc = 0; dc < guide_px; dc++) {
                int64_t c = top[2 * i + 1] + dc;
                c = c < 0 ? 0 : (c > w - 1 ? w - 1 : c);
                g[(r - r0) * sw + (c - x0 + before)] = 1;
            }
        }
    }
    for (int64_t r = 0; r < gh; r++) { /* the guide per cell, then each row dilated along it */
        uint8_t *s = g + r * sw;
        for (int64_t x = 0; x < vw; x++) band[x] += s[x + before];
        if ((r + r0 + 1) % px == 0 || r == gh - 1) flush_blocks(band, x0, vw, px, cells + ((r + r0) / px) * cols);
        uint8_t *restrict from = s, *restrict to = tmp;
        for (int64_t span = 1; span < win;) { /* from[x] = any of s[x .. x + span - 1] */
            int64_t step = span < win - span ? span : win - span;
            for (int64_t x = 0; x < sw - step; x++) to[x] = from[x] | from[x + step];
            for (int64_t x = sw - step; x < sw; x++) to[x] = from[x];
            uint8_t *swap = from;
            from = to;
            to = swap;
            span += step;
        }
        if (from != s) memcpy(s, from, (size_t)sw);
    }
    for (int64_t i = 0; i < ncell; i++) guide[i] = (double)cells[i] / (double)(px * px);
    memset(cells, 0, (size_t)ncell * sizeof(int64_t));
    /* down the columns: the window of row y holds rows y - before .. y + after of g (zero outside r0..r1) */
    for (int64_t r = (y0 - before > r0 ? y0 - before : r0); r <= (y0 + after < r1 ? y0 + after : r1); r++)
        for (int64_t x = 0; x < vw; x++) cnt[x] += g[(r - r0) * sw + x];
    for (int64_t y = y0; y <= y1; y++) {
        for (int64_t x = 0; x < vw; x++) band[x] += cnt[x] > 0;
        if ((y + 1) % px == 0 || y == y1) flush_blocks(band, x0, vw, px, cells + (y / px) * cols);
        int64_t drop = y - before, add = y + after + 1;
        if (drop >= r0 && drop <= r1) {
            const uint8_t *s = g + (drop - r0) * sw;
            for (int64_t x = 0; x < vw; x++) cnt[x] -= s[x];
        }
        if (add >= r0 && add <= r1) {
            const uint8_t *s = g + (add - r0) * sw;
            for (int64_t x = 0; x < vw; x++) cnt[x] += s[x];
        }
    }
    for (int64_t i = 0; i < ncell; i++) region[i] = (double)cells[i] / (double)(px * px);
    status = 0;
done:
    free(top);
    free(g);
    free(tmp);
    free(cnt);
    free(band);
    free(cells);
    return status;
}

static PyObject *py_route_cells(PyObject *self, PyObject *args) {
    PyObject *o_wp, *o_counts;
    long long rows, cols, px, guide_px, before, after;
    double half;
    if (!PyArg_ParseTuple(args, "OOLLLLdLL", &o_wp, &o_counts, &rows, &cols, &px, &guide_px, &half, &before, &after))
        return NULL;
    if (rows < 1 || cols < 1 || px < 1 || guide_px < 1 || before < 0 || after < 0 || before + after >= 65535)
        return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld, px %lld, guide %lld or window %lld, %lld", rows,
                            cols, px, guide_px, before, after);
    Py_buffer bw, bc;
    if (get_buffer(o_wp, &bw, 8, 0, 0, "waypoints") != 0) return NULL;
    int64_t k = bw.len / 16;
    if (get_buffer(o_counts, &bc, 8, k > 0 ? k - 1 : 0, 0, "counts") != 0) {
        PyBuffer_Release(&bw);
        return NULL;
    }
    PyObject *o_region = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(rows * cols * 8));
    PyObject *o_guide = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(rows * cols * 8));
    int status = -1;
    if (o_region && o_guide) {
        double *region = (double *)PyByteArray_AS_STRING(o_region), *guide = (double *)PyByteArray_AS_STRING(o_guide);
        Py_BEGIN_ALLOW_THREADS
        status = route_cells_run((const double *)bw.buf, k, (const int64_t *)bc.buf, rows, cols, px, guide_px, half,
                                 before, after, region, guide);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&bw);
    PyBuffer_Release(&bc);
    if (status < 0) {
        Py_XDECREF(o_region);
        Py_XDECREF(o_guide);
        return PyErr_Occurred() ? NULL : PyErr_NoMemory();
    }
    return Py_BuildValue("NN", o_region, o_guide);
}

/* scipy.ndimage.gaussian_filter of an h x w double array as planning.priors.gaussian_blur computes it: down the
 * columns, then along the rows, `reflect` border (repeated for lines shorter than the kernel), each value
 * w[r] * centre, then + (left_j + right_j) * w[r - j] for j = r .. 1 (whole rows at a time, so the inner loops run
 * over contiguous memory; each value sees the same operations in the same order). 0, or -1 out of memory. */
VECTORIZE static int gauss_blur_run(const double *src, int64_t h, int64_t w, const double *wt, int64_t radius,
                                    double *out) {
    int64_t longest = h > w ? h : w;
    int64_t *idx = malloc((size_t)(longest + 2 * radius) * sizeof(int64_t));
    double *mid = malloc((size_t)(h * w) * sizeof(double)), *pad = malloc((size_t)(w + 2 * radius) * sizeof(double));
    if (!idx || !mid || !pad) {
        free(idx);
        free(mid);
        free(pad);
        return -1;
    }
    for (int64_t i = 0; i < h + 2 * radius; i++) { /* numpy.mod(i - radius, 2h), then reflect */
        int64_t q = (i - radius) % (2 * h);
        if (q < 0) q += 2 * h;
        idx[i] = q >= h ? 2 * h - 1 - q : q;
    }
    for (int64_t i = 0; i < h; i++) { /* down the columns: row i of mid from rows idx[i .. i + 2r] of src */
        double *restrict acc = mid + i * w;
        const double *centre = src + idx[i + radius] * w;
        for (int64_t x = 0; x < w; x++) acc[x] = centre[x] * wt[radius];
        for (int64_t j = radius; j > 0; j--) {
            const double *restrict lo = src + idx[i + radius - j] * w, *restrict hi = src + idx[i + radius + j] * w;
            double c = wt[radius - j];
            for (int64_t x = 0; x < w; x++) acc[x] = acc[x] + (lo[x] + hi[x]) * c;
        }
    }
    for (int64_t i = 0; i < w + 2 * radius; i++) {
        int64_t q = (i - radius) % (2 * w);
        if (q < 0) q += 2 * w;
        idx[i] = q >= w ? 2 * w - 1 - q : q;
    }
    for (int64_t r = 0; r < h; r++) { /* along the rows: the row reflected into pad, then the same sums */
        const double *row = mid + r * w;
        double *restrict acc = out + r * w;
        for (int64_t i = 0; i < w + 2 * radius; i++) pad[i] = row[idx[i]];
        for (int64_t x = 0; x < w; x++) acc[x] = pad[x + radius] * wt[radius];
        for (int64_t j = radius; j > 0; j--) {
            const double *restrict lo = pad + radius - j, *restrict hi = pad + radius + j;
            double c = wt[radius - j];
            for (int64_t x = 0; x < w; x++) acc[x] = acc[x] + (lo[x] + hi[x]) * c;
        }
    }
    free(idx);
    free(mid);
    free(pad);
    return 0;
}

static PyObject *py_gauss_blur(PyObject *self, PyObject *args) {
    PyObject *o_values, *o_weights;
    long long h, w, radius;
    if (!PyArg_ParseTuple(args, "OLLOL", &o_values, &h, &w, &o_weights, &radius)) return NULL;
    if (h < 1 || w < 1 || radius < 0)
        return PyErr_Format(PyExc_ValueError, "bad array %lldx%lld or radius %lld", h, w, radius);
    Py_buffer bv, bw;
    if (get_buffer(o_values, &bv, 8, (Py_ssize_t)(h * w), 0, "values") != 0) return NULL;
    if (get_buffer(o_weights, &bw, 8, (Py_ssize_t)(2 * radius + 1), 0, "weights") != 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(h * w * 8));
    int status = -1;
    if (out) {
        double *dst = (double *)PyByteArray_AS_STRING(out);
        Py_BEGIN_ALLOW_THREADS
        status = gauss_blur_run((const double *)bv.buf, h, w, (const double *)bw.buf, radius, dst);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&bv);
    PyBuffer_Release(&bw);
    if (status < 0) {
        Py_XDECREF(out);
        return PyErr_Occurred() ? NULL : PyErr_NoMemory();
    }
    return out;
}

/* ---------------------------------------------------------------- Eq. 6's distance (planning.priors) */

/* sources.exact_distance_field: 4-connected moves to `src` as doubles; where a cell cannot reach it (blocked cells
 * included), (the largest finite distance, 0 when none) + |row - src row| + |col - src col|, summed in that order.
 * 0, or -1 out of memory. */
static int far_field_run(const uint8_t *blocked, int64_t h, int64_t w, int64_t src, double *out) {
    int64_t n = h * w, top = -1;
    int64_t *dist = malloc((size_t)n * sizeof(int64_t));
    if (!dist || bfs4_run(blocked, h, w, src, dist) != 0) {
        free(dist);
        return -1;
    }
    for (int64_t i = 0; i < n; i++)
        if (dist[i] > top) top = dist[i];
    double far = top >= 0 ? (double)top : 0.0;
    int64_t gr = src / w, gc = src % w;
    for (int64_t r = 0; r < h; r++) {
        double base = far + (double)(r > gr ? r - gr : gr - r);
        for (int64_t c = 0; c < w; c++) {
            int64_t i = r * w + c;
            out[i] = dist[i] >= 0 ? (double)dist[i] : base + (double)(c > gc ? c - gc : gc - c);
        }
    }
    free(dist);
    return 0;
}

static PyObject *py_far_field(PyObject *self, PyObject *args) {
    PyObject *o_blocked;
    long long h, w, src;
    if (!PyArg_ParseTuple(args, "OLLL", &o_blocked, &h, &w, &src)) return NULL;
    if (h < 1 || w < 1 || h > INT32_MAX || w > INT32_MAX || src < 0 || src >= h * w)
        return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld or source cell %lld", h, w, src);
    Py_buffer b;
    if (get_buffer(o_blocked, &b, 1, (Py_ssize_t)(h * w), 0, "blocked") != 0) return NULL;
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(h * w * 8));
    int status = -1;
    if (out) {
        double *dst = (double *)PyByteArray_AS_STRING(out);
        Py_BEGIN_ALLOW_THREADS
        status = far_field_run((const uint8_t *)b.buf, h, w, src, dst);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&b);
    if (status < 0) {
        Py_XDECREF(out);
        return PyErr_Occurred() ? NULL : PyErr_NoMemory();
    }
    return out;
}

/* planning.priors.snapped_distance: per cell, with m = |row - g0| + |col - g1| and x = max(d - m, 0),
 * (m + 2 * rint(x / 2)) + ties, ties = tie * straight [+ weight * (1 - near)] (straight: numpy's hypot of the
 * cell's offsets, given): numpy's operations in numpy's order (np.round is rint, half to even). `near` may be NULL. */
static void snapped_run(const double *d, const double *near, const double *straight, int64_t h, int64_t w, int64_t g0,
                        int64_t g1, double tie, double weight, double *out) {
    for (int64_t r = 0; r < h; r++) {
        for (int64_t c = 0; c < w; c++) {
            int64_t i = r * w + c, dr = r - g0, dc = c - g1;
            double m = (double)((dr < 0 ? -dr : dr) + (dc < 0 ? -dc : dc));
            double x = d[i] - m;
            x = x > 0.0 ? x : 0.0;
            double ties = tie * straight[i];
            if (near) ties = ties + weight * (1.0 - near[i]);
            out[i] = (m + 2.0 * rint(x / 2.0)) + ties;
        }
    }
}

static PyObject *py_snapped(PyObject *self, PyObject *args) {
    PyObject *o_d, *o_near, *o_straight;
    long long h, w, g0, g1;
    double tie, weight;
    if (!PyArg_ParseTuple(args, "OOOLLLLdd", &o_d, &o_near, &o_straight, &h, &w, &g0, &g1, &tie, &weight)) return NULL;
    if (h < 1 || w < 1) return PyErr_Format(PyExc_ValueError, "bad grid %lldx%lld", h, w);
    Py_buffer bd, bn, bs;
    int has_near = o_near != Py_None;
    if (get_buffer(o_d, &bd, 8, (Py_ssize_t)(h * w), 0, "distance") != 0) return NULL;
    if (get_buffer(o_straight, &bs, 8, (Py_ssize_t)(h * w), 0, "straight") != 0) {
        PyBuffer_Release(&bd);
        return NULL;
    }
    if (has_near && get_buffer(o_near, &bn, 8, (Py_ssize_t)(h * w), 0, "nearness") != 0) {
        PyBuffer_Release(&bd);
        PyBuffer_Release(&bs);
        return NULL;
    }
    PyObject *out = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(h * w * 8));
    if (out) {
        double *dst = (double *)PyByteArray_AS_STRING(out);
        const double *near = has_near ? (const double *)bn.buf : NULL;
        Py_BEGIN_ALLOW_THREADS
        snapped_run((const double *)bd.buf, near, (const double *)bs.buf, h, w, g0, g1, tie, weight, dst);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&bd);
    PyBuffer_Release(&bs);
    if (has_near) PyBuffer_Release(&bn);
    return out;
}

/* ---------------------------------------------------------------- the module */

static PyMethodDef methods[] = {
    {"train", py_train, METH_VARARGS,
     "train(nxt, start, goal, r_c, q, seed, alpha, gamma, eps_thr, max_steps, max_episodes, window, r_collision, "
     "r_goal, r_revisit) -> (n_done, steps, returns, success, greedy_len, conv_episode, conv_steps, best_len, best); "
     "arrays as bytearrays (int64, float64, bool, int64, int64); q is updated in place."},
    {"draws", py_draws, METH_VARARGS, "draws(seed, n) -> bytearray of n uint64 generator outputs."},
    {"astar8", py_astar8, METH_VARARGS,
     "astar8(blocked, h, w, s_idx, g_idx, corner_cutting) -> (path bytearray int64, cost, expanded)."},
    {"first_blocked", py_first_blocked, METH_VARARGS,
     "first_blocked(obstacles, h, w, r0, c0, r1, c1) -> (found, row, col)."},
    {"shortcut", py_shortcut, METH_VARARGS, "shortcut(obstacles, h, w, pts) -> bytearray of int64 kept indices."},
    {"supercover", py_supercover, METH_VARARGS, "supercover(r0, c0, r1, c1) -> bytearray of int64 (row, col) pairs."},
    {"bfs4", py_bfs4, METH_VARARGS,
     "bfs4(blocked, h, w, src) -> bytearray of h*w int64 4-connected move counts from src (-1: unreachable/blocked)."},
    {"bottleneck4", py_bottleneck4, METH_VARARGS,
     "bottleneck4(values, blocked, h, w, s, g) -> the widest 4-connected path's smallest value (-inf: none)."},
    {"route_cells", py_route_cells, METH_VARARGS,
     "route_cells(waypoints, counts, rows, cols, px, guide_px, half, before, after) -> (region, guide) bytearrays of "
     "rows*cols float64: the exact source's drawing per cell."},
    {"far_field", py_far_field, METH_VARARGS,
     "far_field(blocked, h, w, src) -> bytearray of h*w float64: pipeline.sources.exact_distance_field."},
    {"snapped", py_snapped, METH_VARARGS,
     "snapped(distance, nearness or None, straight, h, w, g0, g1, tie, weight) -> bytearray of h*w float64: "
     "planning.priors.snapped_distance."},
    {"gauss_blur", py_gauss_blur, METH_VARARGS,
     "gauss_blur(values, h, w, weights, radius) -> bytearray of h*w float64: planning.priors.gaussian_blur."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_kernels",
    "ndrql's compiled kernels ahead of time (C99): Q-learning, the 8-connected A*, segment tests, grid fields. "
    "Bit-identical ports of the numba kernels, which stay as the reference and the fallback.",
    -1, methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__kernels(void) {
    init_select();
    return PyModule_Create(&module);
}
