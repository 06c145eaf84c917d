/* The A* kernel of behaviours/nav/astar.py in C: the same graph, heap order and arithmetic.
 *
 * Why C: the Python kernel (flat indices, precomputed neighbour offsets, heapq) expands about
 * 280k cells/s on this machine; a 400x400 grid with an inflated map expands most of its 160k
 * cells, half a second against the 100 ms the planner is allowed (issue 16). Here a cell costs
 * tens of nanoseconds. astar.py says what the graph is; the tests hold the two to the same path.
 *
 * Ties: the heap orders (f, index) lexicographically, as Python's heapq orders tuples, and
 * f, g and h are computed in the same order of double operations (no -ffast-math).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

typedef struct {
    double f;
    Py_ssize_t index;
} Entry;

typedef struct {
    Entry *items;
    Py_ssize_t size, capacity;
} Heap;

static int less(const Entry *a, const Entry *b)
{
    return a->f < b->f || (a->f == b->f && a->index < b->index);
}

static int heap_push(Heap *h, double f, Py_ssize_t index)
{
    if (h->size == h->capacity) {
        Py_ssize_t capacity = h->capacity ? 2 * h->capacity : 1024;
        Entry *items = realloc(h->items, (size_t)capacity * sizeof(Entry));
        if (!items)
            return -1;
        h->items = items;
        h->capacity = capacity;
    }
    Py_ssize_t i = h->size++;
    Entry e = {f, index};
    while (i > 0) {
        Py_ssize_t up = (i - 1) / 2;
        if (!less(&e, &h->items[up]))
            break;
        h->items[i] = h->items[up];
        i = up;
    }
    h->items[i] = e;
    return 0;
}

static Entry heap_pop(Heap *h)
{
    Entry top = h->items[0];
    Entry last = h->items[--h->size];
    Py_ssize_t i = 0;
    for (;;) {
        Py_ssize_t child = 2 * i + 1;
        if (child >= h->size)
            break;
        if (child + 1 < h->size && less(&h->items[child + 1], &h->items[child]))
            child++;
        if (!less(&h->items[child], &last))
            break;
        h->items[i] = h->items[child];
        i = child;
    }
    if (h->size > 0)
        h->items[i] = last;
    return top;
}

static double octile(Py_ssize_t cell, Py_ssize_t cols, Py_ssize_t goal_r, Py_ssize_t goal_c,
                     double resolution)
{
    Py_ssize_t r = cell / cols, c = cell % cols;
    Py_ssize_t dr = r > goal_r ? r - goal_r : goal_r - r;
    Py_ssize_t dc = c > goal_c ? c - goal_c : goal_c - c;
    Py_ssize_t low = dr < dc ? dr : dc;
    return ((double)(dr + dc) + (sqrt(2.0) - 2.0) * (double)low) * resolution;
}

static PyObject *search(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *cost_obj;
    Py_ssize_t start, goal;
    double resolution;
    if (!PyArg_ParseTuple(args, "Onnd", &cost_obj, &start, &goal, &resolution))
        return NULL;
    Py_buffer view;
    if (PyObject_GetBuffer(cost_obj, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return NULL;
    if (view.ndim != 2 || view.itemsize != sizeof(double) || !view.format
        || view.format[0] != 'd') {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_ValueError, "cost must be a C-contiguous 2-D float64 array");
        return NULL;
    }
    const double *cost = view.buf;
    const Py_ssize_t rows = view.shape[0], cols = view.shape[1], n = rows * cols;
    if (start < 0 || start >= n || goal < 0 || goal >= n) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_IndexError, "start or goal is outside the grid");
        return NULL;
    }
    double *g = malloc((size_t)n * sizeof(double));
    Py_ssize_t *parent = malloc((size_t)n * sizeof(Py_ssize_t));
    uint8_t *closed = calloc((size_t)n, 1);
    Heap heap = {NULL, 0, 0};
    PyObject *result = NULL;
    if (!g || !parent || !closed)
        goto nomem;
    for (Py_ssize_t i = 0; i < n; i++) {
        g[i] = INFINITY;
        parent[i] = -1;
    }
    const double diag = sqrt(2.0) * resolution;
    const int d_row[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
    const int d_col[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
    const Py_ssize_t goal_r = goal / cols, goal_c = goal % cols;
    Py_ssize_t expanded = 0;
    int found = 0;
    g[start] = 0.0;
    if (heap_push(&heap, octile(start, cols, goal_r, goal_c, resolution), start) < 0)
        goto nomem;
    while (heap.size > 0) {
        Entry top = heap_pop(&heap);
        Py_ssize_t cur = top.index;
        if (closed[cur])
            continue;
        closed[cur] = 1;
        expanded++;
        if (cur == goal) {
            found = 1;
            break;
        }
        Py_ssize_t r = cur / cols, c = cur % cols;
        double g_cur = g[cur];
        for (int k = 0; k < 8; k++) {
            Py_ssize_t nr = r + d_row[k], nc = c + d_col[k];
            if (nr < 0 || nr >= rows || nc < 0 || nc >= cols)
                continue;
            Py_ssize_t next = nr * cols + nc;
            double step = cost[next];
            if (isinf(step) || closed[next])
                continue;
            double length = (d_row[k] && d_col[k]) ? diag : resolution;
            double g_new = g_cur + length * step;
            if (g_new < g[next]) {
                g[next] = g_new;
                parent[next] = cur;
                if (heap_push(&heap, g_new + octile(next, cols, goal_r, goal_c, resolution),
                              next) < 0)
                    goto nomem;
            }
        }
    }
    PyObject *cells = PyList_New(0);
    if (!cells)
        goto done;
    if (found) {
        Py_ssize_t count = 0;
        for (Py_ssize_t at = goal; at >= 0; at = parent[at])
            count++;
        Py_DECREF(cells);
        cells = PyList_New(count);
        if (!cells)
            goto done;
        Py_ssize_t i = count;
        for (Py_ssize_t at = goal; at >= 0; at = parent[at]) {
            PyObject *value = PyLong_FromSsize_t(at);
            if (!value) {
                Py_DECREF(cells);
                goto done;
            }
            PyList_SET_ITEM(cells, --i, value);
        }
    }
    result = Py_BuildValue("(Ndn)", cells, found ? g[goal] : INFINITY, expanded);
    goto done;
nomem:
    PyErr_NoMemory();
done:
    free(g);
    free(parent);
    free(closed);
    free(heap.items);
    PyBuffer_Release(&view);
    return result;
}

static PyMethodDef methods[] = {
    {"search", search, METH_VARARGS,
     "search(cost, start, goal, resolution_m) -> ([cell, ...], cost, expanded)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "behaviours.nav._astar",
    "The planner's A* kernel in C; see behaviours/nav/astar.py.", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__astar(void)
{
    return PyModule_Create(&module);
}
