/* The leaping ray traversal of beliefloc/continuous/raycast.py, one ray at a time in C.
 *
 * raycast.py's _traverse walks every ray together, a NumPy pass per step; a million-pose lattice casts
 * twelve million rays, and the passes' bookkeeping was most of the pose lattice's build (the depot: 5.8 of
 * 9.5 s). This walks each ray to its end in turn, the same state machine on the same numbers: the rays'
 * state is set up by raycast.py (_Rays: start points put on pixel edges, directions, crossings, the pixel
 * entered, which rays start blocked), and every later value is computed here by the same operations in the
 * same order -- the ranges are the NumPy traversal's bit for bit (built with -ffp-contract=off).
 *
 * A ray WALKS (Amanatides & Woo's traversal, with the exact model's corner and edge rules) until it is in a
 * pixel with room around it, then FLIES by that room (the image's distance transform, less 1.5 pixels)
 * until it lands where there is little, and walks again. It ends where a blocked pixel stops it (its range
 * written), or beyond its reach or off the image (its range stays +inf).
 *
 * Nothing here trusts its arguments: lengths are checked against each other, and a pixel is read only
 * once its row and column are known to lie in the image.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>

#define LEAP_MIN 1.0 /* raycast._LEAP_MIN */
#define CORNER 1e-9  /* raycast._CORNER */

typedef struct {
    const uint8_t *blocked;  /* rows from the top, as the image stores them */
    const double *clearance; /* the same layout */
    Py_ssize_t height, width;
} Image;

static inline int inside(const Image *im, int64_t col, int64_t row) {
    return col >= 0 && col < im->width && row >= 0 && row < im->height;
}

/* the pixel (col, row), rows counted up from the bottom; outside the image: not blocked */
static inline int blocked_at(const Image *im, int64_t col, int64_t row) {
    return inside(im, col, row) && im->blocked[(im->height - 1 - row) * im->width + col];
}

static inline double clearance_at(const Image *im, int64_t col, int64_t row) {
    return im->clearance[(im->height - 1 - row) * im->width + col];
}

/* _Rays._crossing for one ray and one axis */
static inline double crossing(int64_t index, double u, double du, double delta, double t) {
    double ahead = du > 0 ? ((double)(index + 1) - u) * delta : (du < 0 ? (u - (double)index) * delta : INFINITY);
    return t + ahead;
}

/* _Rays._pixel for one coordinate */
static inline int64_t pixel(double u, double du) { return du >= 0 ? (int64_t)floor(u) : (int64_t)ceil(u) - 1; }

typedef struct {
    const double *u0, *v0, *du, *dv, *delta_c, *delta_r, *limit;
    const int64_t *step_c, *step_r;
    const uint8_t *edge_c, *edge_r;
    int64_t *col, *row;
    double *next_c, *next_r, *t, *result;
} Rays;

/* _Rays.step for ray i; returns 1 while it travels on */
static int step(const Image *im, Rays *rs, Py_ssize_t i) {
    double nc = rs->next_c[i], nr = rs->next_r[i];
    int64_t col = rs->col[i], row = rs->row[i];
    int corner = fabs(nc - nr) <= CORNER;
    int cross_c = nc < nr || corner, cross_r = nr < nc || corner;
    double t_new = nc < nr ? nc : nr; /* np.minimum: either when equal */
    int64_t c = col + (cross_c ? rs->step_c[i] : 0), r = row + (cross_r ? rs->step_r[i] : 0);
    rs->col[i] = c;
    rs->row[i] = r;
    rs->t[i] = t_new;
    rs->next_c[i] = cross_c ? nc + rs->delta_c[i] : nc;
    rs->next_r[i] = cross_r ? nr + rs->delta_r[i] : nr;
    int beyond = t_new > rs->limit[i];
    int in = inside(im, c, r);
    int hit = !beyond && in && im->blocked[(im->height - 1 - r) * im->width + c];
    if (corner && !beyond && !hit) hit = blocked_at(im, c, row) && blocked_at(im, col, r);
    int ec = rs->edge_c[i] != 0, er = rs->edge_r[i] != 0;
    if (!beyond && (ec || er)) {
        int here = blocked_at(im, col, row) || blocked_at(im, c, r);
        int across = blocked_at(im, col - ec, row - er) || blocked_at(im, c - ec, r - er);
        hit = here && across;
    }
    if (hit) rs->result[i] = t_new;
    return !(beyond || !in || hit);
}

/* one ray from where raycast.py's start left it (walking) to its end */
static void travel(const Image *im, Rays *rs, Py_ssize_t i) {
    for (;;) {
        /* walking: leap from a pixel with room around it, else step to the next pixel */
        double jump = clearance_at(im, rs->col[i], rs->row[i]);
        if (!(jump >= LEAP_MIN)) {
            if (!step(im, rs, i)) return;
            continue;
        }
        double t = rs->t[i] + jump;
        for (;;) { /* flying (_Flight.leap) */
            double u = rs->u0[i] + t * rs->du[i], v = rs->v0[i] + t * rs->dv[i];
            double fc = floor(u), fr = floor(v);
            if (!(t <= rs->limit[i]) || !(fc >= 0 && fc < (double)im->width && fr >= 0 && fr < (double)im->height))
                return; /* beyond its reach or off the image: +inf */
            int64_t c = (int64_t)fc, r = (int64_t)fr;
            jump = clearance_at(im, c, r);
            if (jump >= LEAP_MIN) {
                t += jump;
                continue;
            }
            /* landed: the traversal restarted where it is (_Rays.restart) */
            double du = rs->du[i], dv = rs->dv[i];
            int64_t pc = pixel(u, du), pr = pixel(v, dv);
            rs->t[i] = t;
            rs->next_c[i] = crossing(pc, u, du, rs->delta_c[i], t);
            rs->next_r[i] = crossing(pr, v, dv, rs->delta_r[i], t);
            rs->col[i] = pc;
            rs->row[i] = pr;
            if (!inside(im, pc, pr)) return; /* on the image's edge, leaving it */
            break;
        }
    }
}

/* --- arguments ----------------------------------------------------------------------------------- */

static int get(PyObject *obj, Py_buffer *view, int writable, char kind, Py_ssize_t itemsize, const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) return -1;
    const char *format = view->format ? view->format : "B";
    if (*format == '<' || *format == '=' || *format == '@') format++;
    int ok = view->itemsize == itemsize;
    if (kind == 'd') ok = ok && format[0] == 'd';
    else if (kind == 'q') ok = ok && (format[0] == 'q' || format[0] == 'l');
    else ok = ok && (format[0] == '?' || format[0] == 'B' || format[0] == 'b');
    if (!ok) {
        PyErr_Format(PyExc_TypeError, "%s: a contiguous array of the right type is expected", name);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

#define N_ARGS 20

PyDoc_STRVAR(walk_doc,
             "walk(blocked, clearance, u0, v0, du, dv, delta_c, delta_r, limit, step_c, step_r, edge_c, edge_r,\n"
             "     col, row, next_c, next_r, t, result, walking) -> None\n\n"
             "Every ray of `walking` traversed to its end from the state raycast._Rays gave it: its range into\n"
             "result (pixels), or +inf left there. blocked: bool (height, width); clearance: float64, the same\n"
             "shape; per ray: float64 u0 .. limit, next_c, next_r, t, result; int64 step_c, step_r, col, row;\n"
             "bool edge_c, edge_r; walking: int64 ray indices.");

static PyObject *walk(PyObject *self, PyObject *args) {
    PyObject *o[N_ARGS];
    if (!PyArg_UnpackTuple(args, "walk", N_ARGS, N_ARGS, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                           &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17], &o[18],
                           &o[19]))
        return NULL;
    /* kind, itemsize, writable, name */
    static const char kinds[N_ARGS] = {'b', 'd', 'd', 'd', 'd', 'd', 'd', 'd', 'd', 'q',
                                       'q', 'b', 'b', 'q', 'q', 'd', 'd', 'd', 'd', 'q'};
    static const char *names[N_ARGS] = {"blocked", "clearance", "u0", "v0", "du", "dv", "delta_c",
                                        "delta_r", "limit", "step_c", "step_r", "edge_c", "edge_r", "col",
                                        "row", "next_c", "next_r", "t", "result", "walking"};
    Py_buffer b[N_ARGS];
    int got = 0;
    PyObject *out = NULL;
    for (; got < N_ARGS; got++) {
        int writable = got >= 13 && got <= 18;
        Py_ssize_t size = kinds[got] == 'b' ? 1 : 8;
        if (get(o[got], &b[got], writable, kinds[got], size, names[got]) < 0) goto done;
    }
    if (b[0].ndim != 2 || b[1].ndim != 2 || b[0].shape[0] != b[1].shape[0] || b[0].shape[1] != b[1].shape[1]) {
        PyErr_SetString(PyExc_ValueError, "walk: blocked and clearance must be images of one shape");
        goto done;
    }
    Py_ssize_t n = b[2].len / 8;
    for (int k = 2; k < 19; k++) {
        if (b[k].len / b[k].itemsize != n) {
            PyErr_Format(PyExc_ValueError, "walk: %s has not one entry a ray", names[k]);
            goto done;
        }
    }
    Image im = {b[0].buf, b[1].buf, b[0].shape[0], b[0].shape[1]};
    Rays rs = {b[2].buf,  b[3].buf,  b[4].buf,  b[5].buf,  b[6].buf,  b[7].buf,  b[8].buf,
               b[9].buf,  b[10].buf, b[11].buf, b[12].buf, b[13].buf, b[14].buf, b[15].buf,
               b[16].buf, b[17].buf, b[18].buf};
    const int64_t *walking = b[19].buf;
    Py_ssize_t m = b[19].len / 8;
    for (Py_ssize_t k = 0; k < m; k++) {
        if (walking[k] < 0 || walking[k] >= n || !inside(&im, rs.col[walking[k]], rs.row[walking[k]])) {
            PyErr_SetString(PyExc_ValueError, "walk: a walking ray is not a ray inside the image");
            goto done;
        }
    }
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t k = 0; k < m; k++) travel(&im, &rs, walking[k]);
    Py_END_ALLOW_THREADS;
    out = Py_None;
    Py_INCREF(out);
done:
    for (int k = 0; k < got; k++) PyBuffer_Release(&b[k]);
    return out;
}

static PyMethodDef methods[] = {
    {"walk", walk, METH_VARARGS, walk_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_raycast", "The leaping ray traversal, compiled.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__raycast(void) { return PyModule_Create(&module); }
