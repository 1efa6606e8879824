/* Fused passes for the search's successor statistics on large beliefs (issue 28).
 *
 * At 10^7 states an expansion is memory- and logarithm-bound: a prediction written to memory, read back
 * for its b ln b, sum and maximum, and a look's group sums read the belief again. These functions do each
 * in one pass, a chunk at a time while it is in the cache, with the GIL released.
 *
 * The numbers:
 *   - a prediction is the same sum as SciPy's csr_matvec over T_a^T, bit for bit (each entry starts at 0
 *     and adds its row's products in order; built with -ffp-contract=off, so no product is fused);
 *   - sums of b ln b and of b are added in another order than NumPy's pairwise sums, and the logarithm is
 *     glibc's vector one (libmvec, on x86-64 with AVX2) or the C library's: equal to NumPy's to a few ulps
 *     per entry, not bit for bit. Entries <= 0 add nothing to b ln b (0 ln 0 = 0; a belief never holds a
 *     negative entry); a NaN entry is counted, and the caller takes its NumPy path.
 *
 * Nothing here trusts its arguments: every index is checked against the vector it reads, and a bad one
 * makes the call raise ValueError without writing past any buffer.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

#if defined(BELIEFLOC_LIBMVEC) && defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HAVE_MVEC 1
/* glibc's libmvec: log of four doubles, AVX2 vector ABI */
extern __m256d _ZGVdN4v_log(__m256d x);
#endif

#define CHUNK 1024 /* entries a pass handles at a time: 8 kB, in the L1 cache between its two loops */

typedef struct {
    double xlogx; /* sum of b ln b over the entries > 0 */
    double peak;  /* maximum entry */
    Py_ssize_t nan; /* > 0 once a NaN entry was seen */
} Stats;

/* terms[i] = x[i] ln x[i] for x[i] > 0, else 0; returns their sum; the maximum and NaNs into st */
static double xlogx_scalar(const double *x, double *terms, Py_ssize_t n, Stats *st) {
    double sum = 0.0, peak = st->peak;
    for (Py_ssize_t i = 0; i < n; i++) {
        double v = x[i];
        double t = v > 0.0 ? v * log(v) : 0.0;
        if (terms) terms[i] = t;
        sum += t;
        if (v > peak) peak = v;
        else if (v != v) st->nan++;
    }
    st->peak = peak;
    return sum;
}

#ifdef HAVE_MVEC
static int use_avx2 = -1;

__attribute__((target("avx2"))) static double xlogx_avx2(const double *x, double *terms, Py_ssize_t n, Stats *st) {
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    __m256d acc = zero, peak = _mm256_set1_pd(st->peak), nan = zero;
    Py_ssize_t i = 0;
    for (; i + 4 <= n; i += 4) {
        __m256d v = _mm256_loadu_pd(x + i);
        __m256d positive = _mm256_cmp_pd(v, zero, _CMP_GT_OQ);
        __m256d safe = _mm256_blendv_pd(one, v, positive); /* 1 ln 1 = 0 where v <= 0 or NaN */
        __m256d t = _mm256_mul_pd(safe, _ZGVdN4v_log(safe));
        if (terms) _mm256_storeu_pd(terms + i, t);
        acc = _mm256_add_pd(acc, t);
        peak = _mm256_max_pd(v, peak); /* a NaN v gives peak: NaNs are counted apart */
        nan = _mm256_or_pd(nan, _mm256_cmp_pd(v, v, _CMP_UNORD_Q));
    }
    double lanes[4], peaks[4];
    _mm256_storeu_pd(lanes, acc);
    _mm256_storeu_pd(peaks, peak);
    if (_mm256_movemask_pd(nan)) st->nan++;
    double sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for (int k = 0; k < 4; k++)
        if (peaks[k] > st->peak) st->peak = peaks[k];
    return sum + xlogx_scalar(x + i, terms ? terms + i : NULL, n - i, st);
}
#endif

static double xlogx(const double *x, double *terms, Py_ssize_t n, Stats *st) {
#ifdef HAVE_MVEC
    if (use_avx2 < 0) use_avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
    if (use_avx2) return xlogx_avx2(x, terms, n, st);
#endif
    return xlogx_scalar(x, terms, n, st);
}

/* --- buffers ------------------------------------------------------------------------------------- */

/* A C-contiguous 1-d buffer of `itemsize`-byte items whose format letter is in `kinds`. */
static int get_vector(PyObject *obj, Py_buffer *view, int writable, const char *kinds, const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) return -1;
    const char *format = view->format ? view->format : "B";
    if (*format == '@' || *format == '=' || *format == '<') format++;
    if (view->ndim != 1 || format[0] == '\0' || format[1] != '\0' || !strchr(kinds, format[0])) {
        PyErr_Format(PyExc_TypeError, "%s: a 1-d contiguous vector of one of the types '%s' is expected", name, kinds);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static Py_ssize_t length(const Py_buffer *view) { return view->len / view->itemsize; }

/* --- prediction ---------------------------------------------------------------------------------- */

/* out[row] = sum_k data[k] belief[indices[k]] over the CSR row; then b ln b, sum and maximum of the
 * chunk just written. Returns 0, or -1 (an index out of range: nothing past any buffer is touched). */
#define DEFINE_PREDICT(NAME, INDEX)                                                                        \
    static int NAME(const INDEX *indptr, const INDEX *indices, const double *data, Py_ssize_t nnz,        \
                    const double *belief, Py_ssize_t n_in, double *out, Py_ssize_t n_out, Stats *st) {    \
        if ((Py_ssize_t)indptr[0] != 0) return -1;                                                          \
        for (Py_ssize_t start = 0; start < n_out; start += CHUNK) {                                        \
            Py_ssize_t end = start + CHUNK < n_out ? start + CHUNK : n_out;                                \
            for (Py_ssize_t row = start; row < end; row++) {                                               \
                Py_ssize_t first = (Py_ssize_t)indptr[row], last = (Py_ssize_t)indptr[row + 1];           \
                if (last < first || last > nnz) return -1;                                                 \
                double sum = 0.0;                                                                          \
                for (Py_ssize_t k = first; k < last; k++) {                                                \
                    Py_ssize_t column = (Py_ssize_t)indices[k];                                            \
                    if (column < 0 || column >= n_in) return -1;                                           \
                    sum += data[k] * belief[column];                                                       \
                }                                                                                          \
                out[row] = sum;                                                                            \
            }                                                                                              \
            if (st) st->xlogx += xlogx(out + start, NULL, end - start, st);                                \
        }                                                                                                  \
        return 0;                                                                                          \
    }

DEFINE_PREDICT(predict32, int32_t)
DEFINE_PREDICT(predict64, int64_t)

/* The same prediction from T_a's own CSR arrays (T_a^T's CSC form), with no transpose built: out zeroed,
 * each source state's products added onto its targets, sources ascending -- onto every entry the same
 * products in the same order as the row pass above and SciPy's csc_matvec; then the statistics of out in a
 * second pass (the entries are final only once every source is done). */
#define DEFINE_SCATTER(NAME, INDEX)                                                                        \
    static int NAME(const INDEX *indptr, const INDEX *indices, const double *data, Py_ssize_t nnz,        \
                    const double *belief, Py_ssize_t n_in, double *out, Py_ssize_t n_out, Stats *st) {    \
        if ((Py_ssize_t)indptr[0] != 0) return -1;                                                          \
        memset(out, 0, (size_t)n_out * sizeof(double));                                                    \
        for (Py_ssize_t source = 0; source < n_in; source++) {                                             \
            Py_ssize_t first = (Py_ssize_t)indptr[source], last = (Py_ssize_t)indptr[source + 1];         \
            if (last < first || last > nnz) return -1;                                                     \
            double mass = belief[source];                                                                  \
            for (Py_ssize_t k = first; k < last; k++) {                                                    \
                Py_ssize_t target = (Py_ssize_t)indices[k];                                                \
                if (target < 0 || target >= n_out) return -1;                                              \
                out[target] += data[k] * mass;                                                             \
            }                                                                                              \
        }                                                                                                  \
        if (st)                                                                                            \
            for (Py_ssize_t start = 0; start < n_out; start += CHUNK)                                      \
                st->xlogx += xlogx(out + start, NULL, (n_out - start < CHUNK ? n_out - start : CHUNK), st); \
        return 0;                                                                                          \
    }

DEFINE_SCATTER(scatter32, int32_t)
DEFINE_SCATTER(scatter64, int64_t)

static PyObject *stats_tuple(const Stats *st) {
    return Py_BuildValue("ddn", st->xlogx, st->peak, st->nan);
}

PyDoc_STRVAR(predict_doc,
             "predict_stats(indptr, indices, data, belief, out, stats, by_source) -> (sum b ln b, max b, NaN seen)\n\n"
             "out = T_a^T @ belief, bit for bit as SciPy's csr_matvec over T_a^T: (indptr, indices, data) are\n"
             "T_a^T's CSR arrays, or with by_source true T_a's own; with stats true, the statistics of out\n"
             "(else (0, -inf, 0)).");

static PyObject *predict_stats(PyObject *self, PyObject *args) {
    PyObject *o_indptr, *o_indices, *o_data, *o_belief, *o_out;
    int with_stats = 1, by_source = 0;
    if (!PyArg_ParseTuple(args, "OOOOOpp:predict_stats", &o_indptr, &o_indices, &o_data, &o_belief, &o_out,
                          &with_stats, &by_source))
        return NULL;
    Py_buffer indptr, indices, data, belief, out;
    int got = 0, failed = 0;
    Stats st = {0.0, -INFINITY, 0};
    if (get_vector(o_indptr, &indptr, 0, "ilq", "indptr") < 0) goto done;
    got = 1;
    if (get_vector(o_indices, &indices, 0, "ilq", "indices") < 0) goto done;
    got = 2;
    if (get_vector(o_data, &data, 0, "d", "data") < 0) goto done;
    got = 3;
    if (get_vector(o_belief, &belief, 0, "d", "belief") < 0) goto done;
    got = 4;
    if (get_vector(o_out, &out, 1, "d", "out") < 0) goto done;
    got = 5;
    Py_ssize_t n_out = length(&out), nnz = length(&data), rows = by_source ? length(&belief) : n_out;
    if (indptr.itemsize != indices.itemsize || (indptr.itemsize != 4 && indptr.itemsize != 8) ||
        length(&indptr) != rows + 1 || length(&indices) != nnz || n_out < 1) {
        PyErr_SetString(PyExc_ValueError, "predict_stats: the matrix's arrays do not fit each other or out");
        goto done;
    }
    Stats *into = with_stats ? &st : NULL;
    Py_BEGIN_ALLOW_THREADS;
    if (by_source && indptr.itemsize == 4)
        failed = scatter32(indptr.buf, indices.buf, data.buf, nnz, belief.buf, length(&belief), out.buf, n_out, into);
    else if (by_source)
        failed = scatter64(indptr.buf, indices.buf, data.buf, nnz, belief.buf, length(&belief), out.buf, n_out, into);
    else if (indptr.itemsize == 4)
        failed = predict32(indptr.buf, indices.buf, data.buf, nnz, belief.buf, length(&belief), out.buf, n_out, into);
    else
        failed = predict64(indptr.buf, indices.buf, data.buf, nnz, belief.buf, length(&belief), out.buf, n_out, into);
    Py_END_ALLOW_THREADS;
    if (failed) PyErr_SetString(PyExc_ValueError, "predict_stats: an index of the matrix is out of range");
done:
    if (got >= 5) PyBuffer_Release(&out);
    if (got >= 4) PyBuffer_Release(&belief);
    if (got >= 3) PyBuffer_Release(&data);
    if (got >= 2) PyBuffer_Release(&indices);
    if (got >= 1) PyBuffer_Release(&indptr);
    if (PyErr_Occurred()) return NULL;
    return stats_tuple(&st);
}

/* --- statistics of a belief ---------------------------------------------------------------------- */

PyDoc_STRVAR(belief_doc, "belief_stats(belief) -> (sum b ln b over b > 0, max b, NaN seen)");

static PyObject *belief_stats(PyObject *self, PyObject *arg) {
    Py_buffer belief;
    Stats st = {0.0, -INFINITY, 0};
    if (get_vector(arg, &belief, 0, "d", "belief") < 0) return NULL;
    Py_ssize_t n = length(&belief);
    const double *x = belief.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t start = 0; start < n; start += CHUNK)
        st.xlogx += xlogx(x + start, NULL, (n - start < CHUNK ? n - start : CHUNK), &st);
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&belief);
    return stats_tuple(&st);
}

/* --- per-group statistics ------------------------------------------------------------------------ */

/* The labels are bytes, 16-bit or 64-bit integers (a look of a few signature groups: a byte a state, not eight).
 * Returns 1 when a label is not a group. */
#define DEFINE_GROUP_LOOP(NAME, LABEL)                                                                     \
    static int NAME(const double *x, const LABEL *g, Py_ssize_t n, double *m, double *ml, double *pk,     \
                    Py_ssize_t groups, Stats *st) {                                                         \
        for (Py_ssize_t k = 0; k < groups; k++) {                                                           \
            m[k] = 0.0;                                                                                     \
            ml[k] = 0.0;                                                                                    \
            pk[k] = -INFINITY;                                                                              \
        }                                                                                                   \
        double terms[CHUNK];                                                                                \
        for (Py_ssize_t start = 0; start < n; start += CHUNK) {                                             \
            Py_ssize_t count = n - start < CHUNK ? n - start : CHUNK;                                       \
            xlogx(x + start, terms, count, st);                                                             \
            for (Py_ssize_t i = 0; i < count; i++) {                                                        \
                int64_t k = (int64_t)g[start + i];                                                          \
                if (k < 0 || k >= groups) return 1;                                                         \
                double v = x[start + i];                                                                    \
                m[k] += v;                                                                                  \
                ml[k] += terms[i];                                                                          \
                if (v > pk[k]) pk[k] = v;                                                                   \
            }                                                                                               \
        }                                                                                                   \
        return 0;                                                                                           \
    }

DEFINE_GROUP_LOOP(group_loop_u8, uint8_t)
DEFINE_GROUP_LOOP(group_loop_u16, uint16_t)
DEFINE_GROUP_LOOP(group_loop_i64, int64_t)

PyDoc_STRVAR(group_doc,
             "group_stats(belief, label, mass, mass_log_mass, peak) -> NaN seen\n\n"
             "For every group g (label[j] = g): mass[g] = sum b_j, mass_log_mass[g] = sum b_j ln b_j (b_j > 0),\n"
             "peak[g] = max b_j, over its states j, in one pass. The three outputs have one entry per group;\n"
             "label: uint8, uint16 or int64.");

static PyObject *group_stats(PyObject *self, PyObject *args) {
    PyObject *o_belief, *o_label, *o_mass, *o_mlm, *o_peak;
    if (!PyArg_ParseTuple(args, "OOOOO:group_stats", &o_belief, &o_label, &o_mass, &o_mlm, &o_peak)) return NULL;
    Py_buffer belief, label, mass, mlm, peak;
    int got = 0, failed = 0;
    Stats st = {0.0, -INFINITY, 0};
    if (get_vector(o_belief, &belief, 0, "d", "belief") < 0) goto done;
    got = 1;
    if (get_vector(o_label, &label, 0, "BHlq", "label") < 0) goto done;
    got = 2;
    if (get_vector(o_mass, &mass, 1, "d", "mass") < 0) goto done;
    got = 3;
    if (get_vector(o_mlm, &mlm, 1, "d", "mass_log_mass") < 0) goto done;
    got = 4;
    if (get_vector(o_peak, &peak, 1, "d", "peak") < 0) goto done;
    got = 5;
    Py_ssize_t n = length(&belief), groups = length(&mass);
    if ((label.itemsize != 1 && label.itemsize != 2 && label.itemsize != 8) || length(&label) != n ||
        length(&mlm) != groups || length(&peak) != groups) {
        PyErr_SetString(PyExc_ValueError, "group_stats: the vectors' lengths do not fit each other");
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS;
    if (label.itemsize == 1)
        failed = group_loop_u8(belief.buf, label.buf, n, mass.buf, mlm.buf, peak.buf, groups, &st);
    else if (label.itemsize == 2)
        failed = group_loop_u16(belief.buf, label.buf, n, mass.buf, mlm.buf, peak.buf, groups, &st);
    else
        failed = group_loop_i64(belief.buf, label.buf, n, mass.buf, mlm.buf, peak.buf, groups, &st);
    Py_END_ALLOW_THREADS;
    if (failed) PyErr_SetString(PyExc_ValueError, "group_stats: a label is not a group");
done:
    if (got >= 5) PyBuffer_Release(&peak);
    if (got >= 4) PyBuffer_Release(&mlm);
    if (got >= 3) PyBuffer_Release(&mass);
    if (got >= 2) PyBuffer_Release(&label);
    if (got >= 1) PyBuffer_Release(&belief);
    if (PyErr_Occurred()) return NULL;
    return PyLong_FromSsize_t(st.nan);
}

/* --- a Bayes update and a search key --------------------------------------------------------------- */

/* NumPy's pairwise sum of doubles (numpy/_core/src/umath/loops_utils.h.src), leaf for leaf: np.add.reduce
 * over a contiguous vector adds its entries in exactly this tree. Here each leaf's entries are computed
 * (out = belief * column[label]) just before they are summed, while they are in the cache. */
#define DEFINE_WEIGHTED(NAME, LABEL)                                                                       \
    static double NAME(const double *belief, const double *column, Py_ssize_t groups, const LABEL *label,   \
                       double *out, Py_ssize_t n, int *bad) {                                              \
        if (n > 128) {                                                                                      \
            Py_ssize_t half = n / 2;                                                                        \
            half -= half % 8;                                                                               \
            double low = NAME(belief, column, groups, label, out, half, bad);                               \
            return low + NAME(belief + half, column, groups, label + half, out + half, n - half, bad);      \
        }                                                                                                   \
        for (Py_ssize_t i = 0; i < n; i++) {                                                                \
            int64_t g = (int64_t)label[i];                                                                  \
            if (g < 0 || g >= groups) {                                                                     \
                *bad = 1;                                                                                   \
                out[i] = 0.0;                                                                               \
            } else {                                                                                        \
                out[i] = belief[i] * column[g];                                                             \
            }                                                                                               \
        }                                                                                                   \
        return leaf_sum(out, n);                                                                            \
    }

/* A leaf of NumPy's pairwise sum: fewer than 8 entries in order, else eight running sums combined as NumPy does. */
static double leaf_sum(const double *out, Py_ssize_t n) {
    if (n < 8) {
        double sum = 0.0;
        for (Py_ssize_t i = 0; i < n; i++) sum += out[i];
        return sum;
    }
    double r[8];
    for (int j = 0; j < 8; j++) r[j] = out[j];
    Py_ssize_t i = 8;
    for (; i < n - (n % 8); i += 8)
        for (int j = 0; j < 8; j++) r[j] += out[i + j];
    double sum = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; i++) sum += out[i];
    return sum;
}

DEFINE_WEIGHTED(weighted_u8, uint8_t)
DEFINE_WEIGHTED(weighted_u16, uint16_t)
DEFINE_WEIGHTED(weighted_i64, int64_t)

PyDoc_STRVAR(weighted_doc,
             "weighted_sum(belief, column, label, out) -> sum of out\n\n"
             "out = belief * column[label] (an unnormalised Bayes update: column holds one observation's\n"
             "likelihood per signature group; label uint8, uint16 or int64), and its sum, bit for bit as NumPy's\n"
             "product and np.add.reduce.");

static PyObject *weighted_sum(PyObject *self, PyObject *args) {
    PyObject *o_belief, *o_column, *o_label, *o_out;
    if (!PyArg_ParseTuple(args, "OOOO:weighted_sum", &o_belief, &o_column, &o_label, &o_out)) return NULL;
    Py_buffer belief, column, label, out;
    int got = 0, bad = 0;
    double total = 0.0;
    if (get_vector(o_belief, &belief, 0, "d", "belief") < 0) goto done;
    got = 1;
    if (get_vector(o_column, &column, 0, "d", "column") < 0) goto done;
    got = 2;
    if (get_vector(o_label, &label, 0, "BHlq", "label") < 0) goto done;
    got = 3;
    if (get_vector(o_out, &out, 1, "d", "out") < 0) goto done;
    got = 4;
    Py_ssize_t n = length(&belief);
    if ((label.itemsize != 1 && label.itemsize != 2 && label.itemsize != 8) || length(&label) != n ||
        length(&out) != n) {
        PyErr_SetString(PyExc_ValueError, "weighted_sum: the vectors' lengths do not fit each other");
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS;
    if (label.itemsize == 1)
        total = weighted_u8(belief.buf, column.buf, length(&column), label.buf, out.buf, n, &bad);
    else if (label.itemsize == 2)
        total = weighted_u16(belief.buf, column.buf, length(&column), label.buf, out.buf, n, &bad);
    else
        total = weighted_i64(belief.buf, column.buf, length(&column), label.buf, out.buf, n, &bad);
    Py_END_ALLOW_THREADS;
    if (bad) PyErr_SetString(PyExc_ValueError, "weighted_sum: a label is not a group");
done:
    if (got >= 4) PyBuffer_Release(&out);
    if (got >= 3) PyBuffer_Release(&label);
    if (got >= 2) PyBuffer_Release(&column);
    if (got >= 1) PyBuffer_Release(&belief);
    if (PyErr_Occurred()) return NULL;
    return PyFloat_FromDouble(total);
}

PyDoc_STRVAR(round_doc,
             "round_key(belief, resolution, whole) -> (max belief, fits)\n\n"
             "whole = rint(belief * resolution) as 32-bit integers, as NumPy's rint and unsafe cast give for\n"
             "every entry that fits; fits is false when one does not (or is NaN): whole is then not a key.");

static PyObject *round_key(PyObject *self, PyObject *args) {
    PyObject *o_belief, *o_whole;
    double resolution;
    if (!PyArg_ParseTuple(args, "OdO:round_key", &o_belief, &resolution, &o_whole)) return NULL;
    Py_buffer belief, whole;
    if (get_vector(o_belief, &belief, 0, "d", "belief") < 0) return NULL;
    if (get_vector(o_whole, &whole, 1, "i", "whole") < 0) {
        PyBuffer_Release(&belief);
        return NULL;
    }
    if (whole.itemsize != 4 || length(&whole) != length(&belief)) {
        PyBuffer_Release(&whole);
        PyBuffer_Release(&belief);
        PyErr_SetString(PyExc_ValueError, "round_key: whole must be int32 of the belief's length");
        return NULL;
    }
    Py_ssize_t n = length(&belief);
    const double *x = belief.buf;
    int32_t *w = whole.buf;
    double peak = -INFINITY;
    int fits = 1;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t i = 0; i < n; i++) {
        double v = x[i], y = v * resolution;
        /* rint in the default rounding mode, without a call into the C library: below 2^52 in magnitude,
         * adding and taking away 2^52 rounds to the nearest integer, ties to even (as rint does) */
        double r = y >= 0.0 ? (y + 0x1p52) - 0x1p52 : (y - 0x1p52) + 0x1p52;
        if (v > peak) peak = v;
        if (r >= -2147483648.0 && r < 2147483648.0) {
            w[i] = (int32_t)r;
        } else {
            w[i] = 0;
            fits = 0; /* out of range or NaN */
        }
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&whole);
    PyBuffer_Release(&belief);
    return Py_BuildValue("dO", peak, fits ? Py_True : Py_False);
}

static PyMethodDef methods[] = {
    {"weighted_sum", weighted_sum, METH_VARARGS, weighted_doc},
    {"round_key", round_key, METH_VARARGS, round_doc},
    {"predict_stats", predict_stats, METH_VARARGS, predict_doc},
    {"belief_stats", belief_stats, METH_O, belief_doc},
    {"group_stats", group_stats, METH_VARARGS, group_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fused", "Fused passes for the search's successor statistics (see _fused.c).", -1, methods,
};

PyMODINIT_FUNC PyInit__fused(void) {
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
#ifdef HAVE_MVEC
    if (PyModule_AddStringConstant(m, "LOG", "libmvec") < 0) return NULL;
#else
    if (PyModule_AddStringConstant(m, "LOG", "libm") < 0) return NULL;
#endif
    return m;
}
