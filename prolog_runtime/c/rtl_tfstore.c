/*  rtl_tfstore: the store of the tf library in C (prolog_runtime/rtl_tf.pl, docs/tf.md).

    The same tree, the same rules and the same answers as the Prolog road of rtl_tf.pl,
    which stays the reference (tests/test_tf.py runs both roads and tf2's BufferCore on the
    same random scenarios): one store per program (its module name), a frame table
    (frame id atom -> handle, 1..N, in the order frames are first named), per frame its kind
    (none: only named as a parent, static, dynamic) and its records, sorted by stamp
    (integer nanoseconds): a static frame one, a dynamic frame those of the buffer duration.

    Predicates (M the program's module; a time is `latest`, `ns(N)`, `[S, NS]` or a number
    of seconds; a frame id an atom or a string, one leading `/` dropped, inside the release's
    quotes too). Each fails, leaving the Prolog wrapper to raise the error, when an argument
    is not of its expected shape:

      tf_c_add(+M, +Parent, +Child, +Time, +[X,Y,Z], +[QX,QY,QZ,QW], +Kind)
      tf_c_lookup(+M, +Target, +Source, +Time, -Pose, -Stamp, -Result)
      tf_c_parent(+M, +Frame, +Time, -Parent)
      tf_c_frames(+M, -Frames)  tf_c_counts(+M, -Links, -Records, -Bytes)
      tf_c_set_buffer(+M, +Ns)  tf_c_clear(+M)
      tf_c_dump(+M, -Terms)     tf_c_load(+M, +Terms)    (snapshots: rtl_state.pl)

    The arithmetic is the Prolog road's, operation for operation (tf2's formulas).
*/

#include <SWI-Prolog.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DEPTH 1000                  /* tf2's MAX_GRAPH_DEPTH */
#define DEFAULT_BUFFER 10000000000LL
#define NS 1000000000LL

enum { K_NONE = 0, K_STATIC = 1, K_DYNAMIC = 2 };

typedef struct {
    int64_t stamp;
    uint32_t parent;                    /* a handle */
    double v[3], q[4];
} rec;

typedef struct {
    atom_t name;
    int kind;
    rec *recs;                          /* recs[first .. first + n - 1] */
    uint32_t first, n, cap;
} frame;

typedef struct store {
    atom_t program;
    frame *frames;                      /* frames[1 .. count] */
    uint32_t count, cap;
    uint32_t *slots;                    /* open addressing: atom -> handle (0 free) */
    uint32_t nslots;
    int64_t buffer;
    struct store *next;
} store;

static store *stores;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;

static atom_t a_latest, a_static, a_dynamic, a_none, a_ok, a_past, a_future, a_loop;
static functor_t f_ns, f_unknown, f_not_connected, f_extrapolation, f_frame, f_r, f_buffer;

/* ---- stores and frames ------------------------------------------------------------------ */

static store *get_store(atom_t program, int make) {
    for (store *s = stores; s; s = s->next)
        if (s->program == program) return s;
    if (!make) return NULL;
    store *s = calloc(1, sizeof(store));
    if (!s) return NULL;
    s->program = program;
    PL_register_atom(program);
    s->buffer = DEFAULT_BUFFER;
    s->next = stores;
    stores = s;
    return s;
}

static uint32_t hash_atom(atom_t a, uint32_t nslots) {
    uint64_t h = (uint64_t)a * 0x9E3779B97F4A7C15ULL;
    return (uint32_t)(h >> 32) & (nslots - 1);
}

static uint32_t find_frame(store *s, atom_t name) {
    if (!s || !s->nslots) return 0;
    for (uint32_t i = hash_atom(name, s->nslots);; i = (i + 1) & (s->nslots - 1)) {
        uint32_t h = s->slots[i];
        if (!h) return 0;
        if (s->frames[h].name == name) return h;
    }
}

static int rehash(store *s, uint32_t nslots) {
    uint32_t *slots = calloc(nslots, sizeof(uint32_t));
    if (!slots) return FALSE;
    for (uint32_t h = 1; h <= s->count; h++) {
        uint32_t i = hash_atom(s->frames[h].name, nslots);
        while (slots[i]) i = (i + 1) & (nslots - 1);
        slots[i] = h;
    }
    free(s->slots);
    s->slots = slots;
    s->nslots = nslots;
    return TRUE;
}

static uint32_t add_frame(store *s, atom_t name) {
    uint32_t h = find_frame(s, name);
    if (h) return h;
    if (s->count + 1 >= s->cap) {
        uint32_t cap = s->cap ? s->cap * 2 : 16;
        frame *fs = realloc(s->frames, cap * sizeof(frame));
        if (!fs) return 0;
        s->frames = fs;
        s->cap = cap;
    }
    if ((s->count + 1) * 2 >= s->nslots && !rehash(s, s->nslots ? s->nslots * 2 : 32)) return 0;
    h = ++s->count;
    frame *f = &s->frames[h];
    memset(f, 0, sizeof(frame));
    f->name = name;
    PL_register_atom(name);
    uint32_t i = hash_atom(name, s->nslots);
    while (s->slots[i]) i = (i + 1) & (s->nslots - 1);
    s->slots[i] = h;
    return h;
}

static void clear_store(store *s) {
    for (uint32_t h = 1; h <= s->count; h++) {
        free(s->frames[h].recs);
        PL_unregister_atom(s->frames[h].name);
    }
    free(s->frames);
    free(s->slots);
    s->frames = NULL;
    s->slots = NULL;
    s->count = s->cap = s->nslots = 0;
}

/* ---- arguments ---------------------------------------------------------------------------- */

/* The frame id of an atom or a string, one leading slash dropped (inside '"..."' too). */
static int get_frame_id(term_t t, atom_t *out) {
    atom_t a;
    char *s;
    size_t len;
    if (PL_get_atom(t, &a)) {
        const char *text = PL_atom_nchars(a, &len);
        if (text) {
            if (len > 0 && text[0] == '/') { *out = PL_new_atom_nchars(len - 1, text + 1); goto made; }
            if (len > 1 && text[0] == '"' && text[1] == '/') goto slow;
            *out = a;
            return TRUE;
        }
        const pl_wchar_t *w = PL_atom_wchars(a, &len);
        if (!w) return FALSE;
        if (len > 0 && w[0] == '/') { *out = PL_new_atom_wchars(len - 1, w + 1); goto made; }
        if (len > 1 && w[0] == '"' && w[1] == '/') goto slow;
        *out = a;
        return TRUE;
    }
    if (!PL_is_string(t)) return FALSE;
slow:
    if (!PL_get_nchars(t, &len, &s, CVT_ATOM | CVT_STRING | REP_UTF8 | BUF_STACK)) return FALSE;
    if (len > 0 && s[0] == '/') { s++; len--; }
    else if (len > 1 && s[0] == '"' && s[1] == '/') { s[1] = '"'; s++; len--; }
    *out = PL_new_atom_mbchars(REP_UTF8, len, s);
made:
    /* a new atom reference: kept by the caller's term refs only while the call lasts */
    {   term_t keep = PL_new_term_ref();
        PL_put_atom(keep, *out);
        PL_unregister_atom(*out);
    }
    return TRUE;
}

static int get_int64_exact(term_t t, int64_t *v) {
    return PL_is_integer(t) && PL_get_int64(t, v);
}

/* A time in nanoseconds (0: the latest). */
static int get_time(term_t t, int64_t *ns) {
    atom_t a;
    double d;
    if (PL_get_atom(t, &a)) {
        if (a == a_latest) { *ns = 0; return TRUE; }
        return FALSE;
    }
    if (PL_is_integer(t)) {
        int64_t s;
        if (!PL_get_int64(t, &s) || s > INT64_MAX / NS || s < INT64_MIN / NS) return FALSE;
        *ns = s * NS;
        return TRUE;
    }
    if (PL_is_float(t)) {
        if (!PL_get_float(t, &d)) return FALSE;
        double x = d * 1e9;
        if (!(x > -9.2e18 && x < 9.2e18)) return FALSE;
        *ns = llround(x);
        return TRUE;
    }
    if (PL_is_functor(t, f_ns)) {
        term_t a1 = PL_new_term_ref();
        _PL_get_arg(1, t, a1);
        return get_int64_exact(a1, ns);
    }
    if (PL_is_pair(t)) {
        term_t head = PL_new_term_ref(), tail = PL_copy_term_ref(t);
        int64_t s, n;
        if (!PL_get_list(tail, head, tail) || !get_int64_exact(head, &s)) return FALSE;
        if (!PL_get_list(tail, head, tail) || !get_int64_exact(head, &n) || !PL_get_nil(tail)) return FALSE;
        if (s > INT64_MAX / NS || s < INT64_MIN / NS) return FALSE;
        *ns = s * NS + n;
        return TRUE;
    }
    return FALSE;
}

/* A list of exactly n elements; numbers into out (all numbers: *numbers = TRUE). */
static int get_numbers(term_t list, int n, double *out, int *numbers) {
    term_t head = PL_new_term_ref(), tail = PL_copy_term_ref(list);
    *numbers = TRUE;
    for (int i = 0; i < n; i++) {
        if (!PL_get_list(tail, head, tail)) return FALSE;
        if (!PL_is_number(head) || !PL_get_float(head, &out[i])) *numbers = FALSE;
    }
    return PL_get_nil(tail);
}

/* ---- adding (tf2's TimeCache::insertData and StaticCache) --------------------------------- */

static int ensure_cap(frame *f, uint32_t need) {
    if (f->first + need <= f->cap) return TRUE;
    uint32_t want = need + need / 4 + 1;        /* room, so that a move to the front is rare */
    if (f->first > 0) {
        memmove(f->recs, f->recs + f->first, f->n * sizeof(rec));
        f->first = 0;
        if (want <= f->cap || (need <= f->cap && f->n < 4)) return TRUE;
    }
    uint32_t cap = f->cap ? f->cap + f->cap / 2 + 1 : 2;
    if (cap < need) cap = need;
    rec *r = realloc(f->recs, (size_t)cap * sizeof(rec));
    if (!r) return FALSE;
    f->recs = r;
    f->cap = cap;
    return TRUE;
}

/* The first record with a stamp >= stamp (n when there is none). */
static uint32_t place(const rec *r, uint32_t n, int64_t stamp) {
    uint32_t lo = 0, hi = n;
    while (lo < hi) {
        uint32_t mid = (lo + hi) >> 1;
        if (r[mid].stamp < stamp) lo = mid + 1; else hi = mid;
    }
    return lo;
}

/* Drop the records older than latest - buffer, keeping the last one. */
static void forget(frame *f, int64_t latest, int64_t buffer) {
    rec *r = f->recs + f->first;
    uint32_t k = 0;
    while (k + 1 < f->n && r[k].stamp + buffer < latest) k++;
    f->first += k;
    f->n -= k;
}

static int insert(store *s, uint32_t ch, int kind, int64_t stamp, uint32_t ph, const double *v, const double *q) {
    frame *f = &s->frames[ch];
    if (kind == K_STATIC) {
        if (!ensure_cap(f, 1)) return FALSE;
        f->first = 0;
        f->n = 1;
        rec *r = &f->recs[0];
        r->stamp = stamp; r->parent = ph;
        memcpy(r->v, v, sizeof(r->v)); memcpy(r->q, q, sizeof(r->q));
        return TRUE;
    }
    if (f->n == 0) {
        if (!ensure_cap(f, 1)) return FALSE;
        f->first = 0;
        f->n = 1;
        rec *r = &f->recs[0];
        r->stamp = stamp; r->parent = ph;
        memcpy(r->v, v, sizeof(r->v)); memcpy(r->q, q, sizeof(r->q));
        return TRUE;
    }
    int64_t latest = f->recs[f->first + f->n - 1].stamp;
    uint32_t at;
    if (stamp > latest) {
        at = f->n;
    } else if (latest > stamp + s->buffer) {
        return TRUE;                                    /* tf2's TF_OLD_DATA */
    } else {
        at = place(f->recs + f->first, f->n, stamp);
        if (at < f->n && f->recs[f->first + at].stamp == stamp) return TRUE;   /* TF_REPEATED_DATA */
    }
    if (!ensure_cap(f, f->n + 1)) return FALSE;
    rec *r = f->recs + f->first;
    if (at < f->n) memmove(r + at + 1, r + at, (f->n - at) * sizeof(rec));
    r[at].stamp = stamp; r[at].parent = ph;
    memcpy(r[at].v, v, sizeof(r[at].v)); memcpy(r[at].q, q, sizeof(r[at].q));
    f->n++;
    forget(f, stamp > latest ? stamp : latest, s->buffer);
    return TRUE;
}

static int finite4(const double *x, int n) {
    for (int i = 0; i < n; i++) if (!isfinite(x[i])) return FALSE;
    return TRUE;
}

static foreign_t pl_add(term_t m, term_t parent, term_t child, term_t time, term_t tv, term_t tq, term_t tkind) {
    atom_t program, pa, ca, kinda;
    int64_t stamp;
    double v[3], q[4];
    int vn, qn;
    if (!PL_get_atom(m, &program) || !PL_get_atom(tkind, &kinda)) return FALSE;
    if (kinda != a_static && kinda != a_dynamic) return FALSE;
    int kind = kinda == a_static ? K_STATIC : K_DYNAMIC;
    if (!get_time(time, &stamp) || PL_is_atom(time)) return FALSE;
    if (!get_frame_id(parent, &pa) || !get_frame_id(child, &ca)) return FALSE;
    if (!get_numbers(tv, 3, v, &vn) || !get_numbers(tq, 4, q, &qn)) return FALSE;
    if (!vn || !qn) return TRUE;
    size_t pl, cl;
    if (pa == ca || !finite4(v, 3) || !finite4(q, 4)) return TRUE;
    if (PL_atom_nchars(pa, &pl) && pl == 0) return TRUE;
    if (PL_atom_nchars(ca, &cl) && cl == 0) return TRUE;
    if (!(fabs(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3] - 1) <= 0.01)) return TRUE;
    pthread_mutex_lock(&lock);
    store *s = get_store(program, TRUE);
    int ok = FALSE;
    if (s) {
        uint32_t ph = add_frame(s, pa);
        uint32_t chh = ph ? add_frame(s, ca) : 0;
        if (chh) {
            frame *f = &s->frames[chh];
            if (f->kind == K_NONE) f->kind = kind;
            ok = insert(s, chh, f->kind, stamp, ph, v, q);
        }
    }
    pthread_mutex_unlock(&lock);
    return ok ? TRUE : PL_resource_error("memory");
}

/* ---- one link (tf2's TimeCache::getData) ---------------------------------------------------- */

typedef struct {
    int kind;                   /* 0 none, 1 past, 2 future */
    int64_t time, earliest, latest;
} error_t_;

/* The transform of frame h at time (0: the latest): its parent (0 when there is none, err set). */
static uint32_t link_data(store *s, uint32_t h, int64_t time, double *v, double *q, error_t_ *err) {
    frame *f = &s->frames[h];
    err->kind = 0;
    rec *r = f->recs + f->first;
    if (f->kind == K_STATIC) {
        memcpy(v, r->v, sizeof(r->v)); memcpy(q, r->q, sizeof(r->q));
        return r->parent;
    }
    rec *last = r + f->n - 1;
    if (time == 0 || time == last->stamp) {
        memcpy(v, last->v, sizeof(last->v)); memcpy(q, last->q, sizeof(last->q));
        return last->parent;
    }
    if (f->n == 1) {
        err->kind = time < last->stamp ? 1 : 2;
        err->time = time; err->earliest = err->latest = last->stamp;
        return 0;
    }
    if (time == r->stamp) {
        memcpy(v, r->v, sizeof(r->v)); memcpy(q, r->q, sizeof(r->q));
        return r->parent;
    }
    if (time > last->stamp || time < r->stamp) {
        err->kind = time > last->stamp ? 2 : 1;
        err->time = time; err->earliest = r->stamp; err->latest = last->stamp;
        return 0;
    }
    uint32_t k = place(r, f->n, time);
    rec *r2 = &r[k];
    if (r2->stamp == time) {
        memcpy(v, r2->v, sizeof(r2->v)); memcpy(q, r2->q, sizeof(r2->q));
        return r2->parent;
    }
    rec *r1 = &r[k - 1];
    if (r1->parent != r2->parent) {
        memcpy(v, r1->v, sizeof(r1->v)); memcpy(q, r1->q, sizeof(r1->q));
        return r1->parent;
    }
    double ratio = (double)(time - r1->stamp) / (double)(r2->stamp - r1->stamp);
    double sr = 1.0 - ratio;
    for (int i = 0; i < 3; i++) v[i] = sr * r1->v[i] + ratio * r2->v[i];
    /* tf2's Quaternion::slerp */
    const double *a = r1->q, *b = r2->q;
    double dot = a[0]*b[0] + a[1]*b[1] + a[2]*b[2] + a[3]*b[3];
    double norms = sqrt((a[0]*a[0] + a[1]*a[1] + a[2]*a[2] + a[3]*a[3]) * (b[0]*b[0] + b[1]*b[1] + b[2]*b[2] + b[3]*b[3]));
    double c = fabs(dot) / norms;
    if (c > 1.0) c = 1.0;
    if (c < -1.0) c = -1.0;
    double theta = acos(c);
    if (theta != 0.0) {
        double d = 1.0 / sin(theta);
        double s0 = sin((1.0 - ratio) * theta);
        double s1 = sin(ratio * theta);
        if (dot < 0) s1 = -s1;
        for (int i = 0; i < 4; i++) q[i] = (a[i] * s0 + b[i] * s1) * d;
    } else {
        memcpy(q, a, 4 * sizeof(double));
    }
    return r1->parent;
}

/* ---- composing ---------------------------------------------------------------------------- */

typedef struct { double v[3], q[4]; } tfm;

static void qmul(const double *a, const double *b, double *o) {
    double x = a[3]*b[0] + a[0]*b[3] + a[1]*b[2] - a[2]*b[1];
    double y = a[3]*b[1] + a[1]*b[3] + a[2]*b[0] - a[0]*b[2];
    double z = a[3]*b[2] + a[2]*b[3] + a[0]*b[1] - a[1]*b[0];
    double w = a[3]*b[3] - a[0]*b[0] - a[1]*b[1] - a[2]*b[2];
    o[0] = x; o[1] = y; o[2] = z; o[3] = w;
}

static void rotate(const double *q, const double *v, double *o) {
    double p[4], qi[4], r[4];
    p[0] = q[3]*v[0] + q[1]*v[2] - q[2]*v[1];
    p[1] = q[3]*v[1] + q[2]*v[0] - q[0]*v[2];
    p[2] = q[3]*v[2] + q[0]*v[1] - q[1]*v[0];
    p[3] = -q[0]*v[0] - q[1]*v[1] - q[2]*v[2];
    qi[0] = -q[0]; qi[1] = -q[1]; qi[2] = -q[2]; qi[3] = q[3];
    qmul(p, qi, r);
    o[0] = r[0]; o[1] = r[1]; o[2] = r[2];
}

static void accumulate(const double *v, const double *q, tfm *acc) {
    double rv[3], nq[4];
    rotate(q, acc->v, rv);
    for (int i = 0; i < 3; i++) acc->v[i] = rv[i] + v[i];
    qmul(q, acc->q, nq);
    memcpy(acc->q, nq, sizeof(nq));
}

static void identity(tfm *t) {
    t->v[0] = t->v[1] = t->v[2] = 0.0;
    t->q[0] = t->q[1] = t->q[2] = 0.0; t->q[3] = 1.0;
}

/* ---- lookups (tf2's walkToTopParent) -------------------------------------------------------- */

enum { R_OK, R_UNKNOWN_TARGET, R_UNKNOWN_SOURCE, R_NOT_CONNECTED, R_EXTRAPOLATION, R_LOOP };

static int walk(store *s, uint32_t th, uint32_t sh, int64_t time, tfm *out, error_t_ *err) {
    tfm sacc, tacc;
    double v[3], q[4];
    error_t_ e, serr;
    identity(&sacc);
    serr.kind = 0;
    uint32_t frame = sh, top = 0;
    for (int depth = 0;; depth++) {
        if (s->frames[frame].kind == K_NONE) { top = frame; break; }
        uint32_t ph = link_data(s, frame, time, v, q, &e);
        if (ph == 0) { top = frame; serr = e; break; }
        if (frame == th) { *out = sacc; return R_OK; }
        if (depth > MAX_DEPTH) return R_LOOP;
        accumulate(v, q, &sacc);
        frame = ph;
    }
    identity(&tacc);
    frame = th;
    for (int depth = 0;; depth++) {
        if (frame == top) {
            /* full_path: inverse(tacc) * sacc */
            double itq[4] = {-tacc.q[0], -tacc.q[1], -tacc.q[2], tacc.q[3]};
            double ntv[3] = {-tacc.v[0], -tacc.v[1], -tacc.v[2]};
            double itv[3], rsv[3];
            rotate(itq, ntv, itv);
            rotate(itq, sacc.v, rsv);
            for (int i = 0; i < 3; i++) out->v[i] = rsv[i] + itv[i];
            qmul(itq, sacc.q, out->q);
            return R_OK;
        }
        if (s->frames[frame].kind == K_NONE) break;
        uint32_t ph = link_data(s, frame, time, v, q, &e);
        if (ph == 0) { *err = e; return R_EXTRAPOLATION; }
        if (frame == sh) {
            double iq[4] = {-tacc.q[0], -tacc.q[1], -tacc.q[2], tacc.q[3]};
            double ntv[3] = {-tacc.v[0], -tacc.v[1], -tacc.v[2]};
            memcpy(out->q, iq, sizeof(iq));
            rotate(iq, ntv, out->v);
            return R_OK;
        }
        if (depth > MAX_DEPTH) return R_LOOP;
        accumulate(v, q, &tacc);
        frame = ph;
    }
    if (serr.kind) { *err = serr; return R_EXTRAPOLATION; }
    return R_NOT_CONNECTED;
}

/* latest stamp (static: 0) and parent of a frame with a link */
static uint32_t latest_of(store *s, uint32_t h, int64_t *latest) {
    frame *f = &s->frames[h];
    rec *last = f->recs + f->first + f->n - 1;
    *latest = f->kind == K_STATIC ? 0 : last->stamp;
    return last->parent;
}

#define INF_TIME INT64_MAX

static int64_t min_time(int64_t latest, int64_t common) {
    if (latest == 0) return common;
    if (common == INF_TIME) return latest;
    return latest < common ? latest : common;
}

/* tf2's getLatestCommonTime: R_OK with *time, or R_LOOP / R_NOT_CONNECTED */
static int latest_common_time(store *s, uint32_t th, uint32_t sh, int64_t *time) {
    if (th == sh) { *time = 0; return R_OK; }
    uint32_t chain_parent[MAX_DEPTH + 3];
    int64_t chain_latest[MAX_DEPTH + 3];
    int n = 0;
    int64_t common = INF_TIME, latest;
    uint32_t frame = sh;
    for (int depth = 0;; depth++) {
        if (s->frames[frame].kind == K_NONE) break;
        uint32_t ph = latest_of(s, frame, &latest);
        common = min_time(latest, common);
        if (ph == th) { *time = common == INF_TIME ? 0 : common; return R_OK; }
        if (depth > MAX_DEPTH) return R_LOOP;
        chain_latest[n] = latest; chain_parent[n] = ph; n++;
        frame = ph;
    }
    common = INF_TIME;
    frame = th;
    for (int depth = 0;; depth++) {
        if (s->frames[frame].kind == K_NONE) return R_NOT_CONNECTED;
        uint32_t ph = latest_of(s, frame, &latest);
        common = min_time(latest, common);
        for (int i = 0; i < n; i++) {
            if (chain_parent[i] == ph) {
                for (int k = 0; k < n; k++) {
                    common = min_time(chain_latest[k], common);
                    if (chain_parent[k] == ph) break;
                }
                *time = common == INF_TIME ? 0 : common;
                return R_OK;
            }
        }
        if (ph == sh) { *time = common == INF_TIME ? 0 : common; return R_OK; }
        if (depth > MAX_DEPTH) return R_LOOP;
        frame = ph;
    }
}

/* The lookup of tf_lookup/6: R_* with out/time/err. */
static int lookup(store *s, atom_t ta, atom_t sa, int64_t time0, tfm *out, int64_t *time, error_t_ *err) {
    uint32_t th = find_frame(s, ta);
    if (ta == sa) {
        identity(out);
        *time = time0;
        if (time0 == 0 && th && s->frames[th].kind != K_NONE) latest_of(s, th, time);
        return R_OK;
    }
    if (!th) return R_UNKNOWN_TARGET;
    uint32_t sh = find_frame(s, sa);
    if (!sh) return R_UNKNOWN_SOURCE;
    *time = time0;
    if (time0 == 0) {
        int r = latest_common_time(s, th, sh, time);
        if (r != R_OK) return r;
    }
    return walk(s, th, sh, *time, out, err);
}

static int unify_result(int r, term_t result, atom_t ta, atom_t sa, const error_t_ *err) {
    switch (r) {
    case R_OK: return PL_unify_atom(result, a_ok);
    case R_UNKNOWN_TARGET: return PL_unify_term(result, PL_FUNCTOR, f_unknown, PL_ATOM, ta);
    case R_UNKNOWN_SOURCE: return PL_unify_term(result, PL_FUNCTOR, f_unknown, PL_ATOM, sa);
    case R_NOT_CONNECTED: return PL_unify_term(result, PL_FUNCTOR, f_not_connected, PL_ATOM, ta, PL_ATOM, sa);
    case R_LOOP: return PL_unify_atom(result, a_loop);
    default:
        return PL_unify_term(result, PL_FUNCTOR, f_extrapolation, PL_ATOM, err->kind == 1 ? a_past : a_future,
                             PL_INT64, err->time, PL_INT64, err->earliest, PL_INT64, err->latest);
    }
}

static foreign_t pl_lookup(term_t m, term_t target, term_t source, term_t ttime, term_t pose, term_t tstamp, term_t result) {
    atom_t program, ta, sa;
    int64_t time0, time = 0;
    if (!PL_get_atom(m, &program) || !get_frame_id(target, &ta) || !get_frame_id(source, &sa)
        || !get_time(ttime, &time0)) return FALSE;
    tfm out;
    error_t_ err = {0, 0, 0, 0};
    pthread_mutex_lock(&lock);
    store *s = get_store(program, FALSE);
    int r;
    if (s) r = lookup(s, ta, sa, time0, &out, &time, &err);
    else if (ta == sa) { identity(&out); time = time0; r = R_OK; }
    else r = R_UNKNOWN_TARGET;
    pthread_mutex_unlock(&lock);
    if (r != R_OK) return unify_result(r, result, ta, sa, &err);
    int64_t secs = time / NS, nsecs = ((time % NS) + NS) % NS;
    return PL_unify_term(pose, PL_LIST, 2,
                         PL_LIST, 3, PL_FLOAT, out.v[0], PL_FLOAT, out.v[1], PL_FLOAT, out.v[2],
                         PL_LIST, 4, PL_FLOAT, out.q[0], PL_FLOAT, out.q[1], PL_FLOAT, out.q[2], PL_FLOAT, out.q[3])
        && PL_unify_term(tstamp, PL_LIST, 2, PL_INT64, secs, PL_INT64, nsecs)
        && PL_unify_atom(result, a_ok);
}

static foreign_t pl_parent(term_t m, term_t tframe, term_t ttime, term_t parent) {
    atom_t program, fa;
    int64_t time;
    if (!PL_get_atom(m, &program) || !get_frame_id(tframe, &fa) || !get_time(ttime, &time)) return FALSE;
    double v[3], q[4];
    error_t_ err = {0, 0, 0, 0};
    atom_t pa = 0;
    pthread_mutex_lock(&lock);
    store *s = get_store(program, FALSE);
    uint32_t h = s ? find_frame(s, fa) : 0;
    if (h && s->frames[h].kind != K_NONE) {
        uint32_t ph = link_data(s, h, time, v, q, &err);
        if (ph) pa = s->frames[ph].name;
    }
    pthread_mutex_unlock(&lock);
    return pa && PL_unify_atom(parent, pa);
}

/* ---- what is known ---------------------------------------------------------------------------- */

static foreign_t pl_frames(term_t m, term_t frames) {
    atom_t program;
    if (!PL_get_atom(m, &program)) return FALSE;
    term_t list = PL_new_term_ref(), head = PL_new_term_ref();
    int ok = TRUE;
    PL_put_nil(list);
    pthread_mutex_lock(&lock);
    store *s = get_store(program, FALSE);
    if (s)
        for (uint32_t h = s->count; ok && h >= 1; h--) {
            PL_put_atom(head, s->frames[h].name);
            ok = PL_cons_list(list, head, list);
        }
    pthread_mutex_unlock(&lock);
    return ok && PL_unify(frames, list);
}

static foreign_t pl_counts(term_t m, term_t links, term_t records, term_t bytes) {
    atom_t program;
    if (!PL_get_atom(m, &program)) return FALSE;
    int64_t nl = 0, nr = 0, nb = 0;
    pthread_mutex_lock(&lock);
    store *s = get_store(program, FALSE);
    if (s) {
        nb = sizeof(store) + (int64_t)s->cap * sizeof(frame) + (int64_t)s->nslots * sizeof(uint32_t);
        for (uint32_t h = 1; h <= s->count; h++) {
            frame *f = &s->frames[h];
            if (f->kind != K_NONE) { nl++; nr += f->n; }
            nb += (int64_t)f->cap * sizeof(rec);
        }
    }
    pthread_mutex_unlock(&lock);
    return PL_unify_int64(links, nl) && PL_unify_int64(records, nr) && PL_unify_int64(bytes, nb);
}

static foreign_t pl_set_buffer(term_t m, term_t tns) {
    atom_t program;
    int64_t ns;
    if (!PL_get_atom(m, &program) || !get_int64_exact(tns, &ns)) return FALSE;
    pthread_mutex_lock(&lock);
    store *s = get_store(program, TRUE);
    if (s) s->buffer = ns;
    pthread_mutex_unlock(&lock);
    return s != NULL;
}

static foreign_t pl_clear(term_t m) {
    atom_t program;
    if (!PL_get_atom(m, &program)) return FALSE;
    pthread_mutex_lock(&lock);
    store *s = get_store(program, FALSE);
    if (s) clear_store(s);
    pthread_mutex_unlock(&lock);
    return TRUE;
}

/* ---- snapshots: the store as data ---------------------------------------------------------------
   frame(Name, Kind) per frame in handle order, then r(Handle, Stamp, Parent, X, Y, Z, QX, QY, QZ, QW)
   per record in stamp order (rtl_tf.pl checks the terms before tf_c_load/2 is called). */

static int dump(store *s, term_t list, term_t item);

static foreign_t pl_dump(term_t m, term_t terms) {
    atom_t program;
    if (!PL_get_atom(m, &program)) return FALSE;
    term_t list = PL_new_term_ref(), item = PL_new_term_ref();
    PL_put_nil(list);
    pthread_mutex_lock(&lock);
    int ok = dump(get_store(program, FALSE), list, item);
    pthread_mutex_unlock(&lock);
    return ok && PL_unify(terms, list);
}

static int dump(store *s, term_t list, term_t item) {
    if (!s) return TRUE;
    for (uint32_t h = s->count; h >= 1; h--) {
        frame *f = &s->frames[h];
        for (uint32_t k = f->n; k-- > 0;) {
            rec *r = &f->recs[f->first + k];
            if (!PL_put_variable(item)
                || !PL_unify_term(item, PL_FUNCTOR, f_r, PL_INT64, (int64_t)h, PL_INT64, r->stamp,
                                  PL_INT64, (int64_t)r->parent, PL_FLOAT, r->v[0], PL_FLOAT, r->v[1],
                                  PL_FLOAT, r->v[2], PL_FLOAT, r->q[0], PL_FLOAT, r->q[1], PL_FLOAT, r->q[2],
                                  PL_FLOAT, r->q[3])
                || !PL_cons_list(list, item, list)) return FALSE;
        }
    }
    for (uint32_t h = s->count; h >= 1; h--) {
        frame *f = &s->frames[h];
        atom_t kind = f->kind == K_STATIC ? a_static : f->kind == K_DYNAMIC ? a_dynamic : a_none;
        if (!PL_put_variable(item)
            || !PL_unify_term(item, PL_FUNCTOR, f_frame, PL_ATOM, f->name, PL_ATOM, kind)
            || !PL_cons_list(list, item, list)) return FALSE;
    }
    return TRUE;
}

static foreign_t pl_load(term_t m, term_t terms) {
    atom_t program;
    if (!PL_get_atom(m, &program)) return FALSE;
    term_t tail = PL_copy_term_ref(terms), head = PL_new_term_ref(), arg = PL_new_term_ref();
    pthread_mutex_lock(&lock);
    store *s = get_store(program, TRUE);
    int ok = s != NULL;
    if (ok) clear_store(s);
    while (ok && PL_get_list(tail, head, tail)) {
        if (PL_is_functor(head, f_frame)) {
            atom_t name, kind;
            _PL_get_arg(1, head, arg);
            ok = PL_get_atom(arg, &name);
            _PL_get_arg(2, head, arg);
            ok = ok && PL_get_atom(arg, &kind);
            uint32_t h = ok ? add_frame(s, name) : 0;
            ok = ok && h == s->count;
            if (ok) s->frames[h].kind = kind == a_static ? K_STATIC : kind == a_dynamic ? K_DYNAMIC : K_NONE;
        } else if (PL_is_functor(head, f_r)) {
            int64_t h, stamp, parent;
            double x[7];
            _PL_get_arg(1, head, arg); ok = get_int64_exact(arg, &h);
            _PL_get_arg(2, head, arg); ok = ok && get_int64_exact(arg, &stamp);
            _PL_get_arg(3, head, arg); ok = ok && get_int64_exact(arg, &parent);
            for (int i = 0; ok && i < 7; i++) { _PL_get_arg(4 + i, head, arg); ok = PL_get_float(arg, &x[i]); }
            ok = ok && h >= 1 && h <= s->count && parent >= 1 && parent <= s->count
                 && s->frames[h].kind != K_NONE;
            if (ok) {
                frame *f = &s->frames[h];
                ok = (f->n == 0 || (f->kind == K_DYNAMIC && f->recs[f->first + f->n - 1].stamp < stamp))
                     && ensure_cap(f, f->n + 1);
                if (ok) {
                    rec *r = &f->recs[f->first + f->n++];
                    r->stamp = stamp; r->parent = (uint32_t)parent;
                    memcpy(r->v, x, sizeof(r->v)); memcpy(r->q, x + 3, sizeof(r->q));
                }
            }
        } else if (PL_is_functor(head, f_buffer)) {
            _PL_get_arg(1, head, arg);
            ok = get_int64_exact(arg, &s->buffer);
        } else ok = FALSE;
    }
    for (uint32_t h = 1; ok && h <= s->count; h++)
        if (s->frames[h].kind != K_NONE && s->frames[h].n == 0) ok = FALSE;
    if (!ok && s) clear_store(s);
    pthread_mutex_unlock(&lock);
    return ok;
}

install_t install_rtl_tfstore(void) {
    a_latest = PL_new_atom("latest");
    a_static = PL_new_atom("static");
    a_dynamic = PL_new_atom("dynamic");
    a_none = PL_new_atom("none");
    a_ok = PL_new_atom("ok");
    a_past = PL_new_atom("past");
    a_future = PL_new_atom("future");
    a_loop = PL_new_atom("loop");
    f_ns = PL_new_functor(PL_new_atom("ns"), 1);
    f_unknown = PL_new_functor(PL_new_atom("unknown_frame"), 1);
    f_not_connected = PL_new_functor(PL_new_atom("not_connected"), 2);
    f_extrapolation = PL_new_functor(PL_new_atom("extrapolation"), 4);
    f_frame = PL_new_functor(PL_new_atom("frame"), 2);
    f_r = PL_new_functor(PL_new_atom("r"), 10);
    f_buffer = PL_new_functor(PL_new_atom("buffer"), 1);
    PL_register_foreign("tf_c_add", 7, pl_add, 0);
    PL_register_foreign("tf_c_lookup", 7, pl_lookup, 0);
    PL_register_foreign("tf_c_parent", 4, pl_parent, 0);
    PL_register_foreign("tf_c_frames", 2, pl_frames, 0);
    PL_register_foreign("tf_c_counts", 4, pl_counts, 0);
    PL_register_foreign("tf_c_set_buffer", 2, pl_set_buffer, 0);
    PL_register_foreign("tf_c_clear", 1, pl_clear, 0);
    PL_register_foreign("tf_c_dump", 2, pl_dump, 0);
    PL_register_foreign("tf_c_load", 2, pl_load, 0);
}
