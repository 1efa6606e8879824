/* LAO*'s bookkeeping (issue 28): the backups and the flow of reach of beliefloc/planning/contingent.py.
 *
 * revise() is _Search._revise, flow() is _Search._flow and reroute() the loop of _Search._reroute, loop for
 * loop: the same floating-point
 * operations in the same order (built with -ffp-contract=off: no fused multiply-adds), the same
 * insertion orders of the dicts and queues, so the same values, policies and expansions. The Python
 * methods stay the reference, and run where no C compiler built this. On the hallway's policy (24 backups
 * and 82 steps of reach an expansion) the Python loops took about 40 % of the search; these take about
 * half as long, most of it the dicts, sets and floats both keep (a fifth of the search saved).
 *
 * The nodes are contingent._Node objects (__slots__): setup() finds each slot's offset in the class's
 * member descriptors once, and every object is checked to be a _Node before a field of it is read or
 * written. Any surprise (a field unset, an exit that is not a (probability, branches) pair) raises.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>

#include <math.h>

static PyTypeObject *node_type = NULL;
static PyObject *frontier = NULL; /* LeafKind.FRONTIER */
static Py_ssize_t off_best, off_children, off_exits, off_leaf, off_parents, off_q, off_reach, off_stale, off_value;

#define SLOT(o, off) (*(PyObject **)((char *)(o) + (off)))

static int slot_offset(PyTypeObject *type, const char *name, Py_ssize_t *out) {
    PyObject *descr = PyDict_GetItemString(type->tp_dict, name); /* borrowed */
    if (descr == NULL || !Py_IS_TYPE(descr, &PyMemberDescr_Type)) {
        PyErr_Format(PyExc_TypeError, "setup: %s is not a slot of %s", name, type->tp_name);
        return -1;
    }
    PyMemberDef *member = ((PyMemberDescrObject *)descr)->d_member;
    if (member->type != T_OBJECT_EX || (member->flags & READONLY)) {
        PyErr_Format(PyExc_TypeError, "setup: %s is not a writable object slot", name);
        return -1;
    }
    *out = member->offset;
    return 0;
}

static PyObject *setup(PyObject *self, PyObject *args) {
    PyObject *type, *kind;
    if (!PyArg_ParseTuple(args, "O!O", &PyType_Type, &type, &kind)) return NULL;
    PyTypeObject *t = (PyTypeObject *)type;
    if (slot_offset(t, "best", &off_best) < 0 || slot_offset(t, "children", &off_children) < 0 ||
        slot_offset(t, "exits", &off_exits) < 0 ||
        slot_offset(t, "leaf", &off_leaf) < 0 || slot_offset(t, "parents", &off_parents) < 0 ||
        slot_offset(t, "q", &off_q) < 0 || slot_offset(t, "reach", &off_reach) < 0 ||
        slot_offset(t, "stale", &off_stale) < 0 || slot_offset(t, "value", &off_value) < 0)
        return NULL;
    Py_INCREF(type);
    Py_INCREF(kind);
    Py_XSETREF(node_type, t);
    Py_XSETREF(frontier, kind);
    Py_RETURN_NONE;
}

/* --- fields ------------------------------------------------------------------------------------ */

static int is_node(PyObject *o) {
    if (node_type == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "_lao.setup() was not called");
        return 0;
    }
    if (Py_TYPE(o) != node_type) {
        PyErr_Format(PyExc_TypeError, "expected a search node, got %s", Py_TYPE(o)->tp_name);
        return 0;
    }
    return 1;
}

/* the field at ``off`` (borrowed), or NULL with AttributeError when it was never set */
static PyObject *field(PyObject *node, Py_ssize_t off) {
    PyObject *v = SLOT(node, off);
    if (v == NULL) PyErr_SetString(PyExc_AttributeError, "a search node's field is unset");
    return v;
}

/* replace the field at ``off`` by ``v`` (a new reference, stolen; NULL: an error already set) */
static int put(PyObject *node, Py_ssize_t off, PyObject *v) {
    if (v == NULL) return -1;
    PyObject *old = SLOT(node, off);
    SLOT(node, off) = v;
    Py_XDECREF(old);
    return 0;
}

static int to_double(PyObject *v, double *x) {
    if (v == NULL) return -1;
    if (PyFloat_CheckExact(v)) {
        *x = PyFloat_AS_DOUBLE(v);
        return 0;
    }
    *x = PyFloat_AsDouble(v);
    return (*x == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

static int field_double(PyObject *node, Py_ssize_t off, double *x) { return to_double(field(node, off), x); }

static int field_index(PyObject *node, Py_ssize_t off, Py_ssize_t *i) {
    PyObject *v = field(node, off);
    if (v == NULL) return -1;
    *i = PyLong_AsSsize_t(v);
    return (*i == -1 && PyErr_Occurred()) ? -1 : 0;
}

/* item ``i`` of a list (borrowed), checked */
static PyObject *list_item(PyObject *list, Py_ssize_t i, const char *what) {
    if (!PyList_Check(list) || i < 0 || i >= PyList_GET_SIZE(list)) {
        PyErr_Format(PyExc_TypeError, "%s: no item %zd", what, i);
        return NULL;
    }
    return PyList_GET_ITEM(list, i);
}

/* a 2-tuple's items (borrowed) */
static int pair(PyObject *t, PyObject **a, PyObject **b, const char *what) {
    if (!PyTuple_Check(t) || PyTuple_GET_SIZE(t) != 2) {
        PyErr_Format(PyExc_TypeError, "%s: not a pair", what);
        return -1;
    }
    *a = PyTuple_GET_ITEM(t, 0);
    *b = PyTuple_GET_ITEM(t, 1);
    return 0;
}

/* an action's Q from the node's exits: ``(cost + Σ p V) / (1 - here)``, infinite when it always comes
 * back (as _Search._revise writes _q out) */
static int exit_q(PyObject *exits, Py_ssize_t action, double cost, double same, double *q) {
    PyObject *exit = list_item(exits, action, "exits"), *here_obj, *others;
    double here;
    if (exit == NULL || pair(exit, &here_obj, &others, "an exit") < 0 || to_double(here_obj, &here) < 0) return -1;
    if (here >= 1.0 - same) {
        *q = INFINITY;
        return 0;
    }
    if (!PyList_Check(others)) {
        PyErr_SetString(PyExc_TypeError, "an exit's branches are not a list");
        return -1;
    }
    double total = cost;
    for (Py_ssize_t i = 0; i < PyList_GET_SIZE(others); i++) {
        PyObject *p_obj, *child;
        double p, v;
        if (pair(PyList_GET_ITEM(others, i), &p_obj, &child, "a branch") < 0 || to_double(p_obj, &p) < 0) return -1;
        if (!is_node(child) || field_double(child, off_value, &v) < 0) return -1;
        total += p * v;
    }
    *q = total / (1.0 - here);
    return 0;
}

/* --- a queue of nodes (owned references), first in first out ------------------------------------ */

typedef struct {
    PyObject **items;
    Py_ssize_t head, tail, size;
} Queue;

static int push(Queue *queue, PyObject *o) {
    if (queue->tail == queue->size) {
        if (queue->head > 0) {
            memmove(queue->items, queue->items + queue->head, (queue->tail - queue->head) * sizeof(PyObject *));
            queue->tail -= queue->head;
            queue->head = 0;
        }
        if (queue->tail == queue->size) {
            Py_ssize_t size = queue->size ? 2 * queue->size : 64;
            PyObject **items = PyMem_Realloc(queue->items, size * sizeof(PyObject *));
            if (items == NULL) {
                PyErr_NoMemory();
                return -1;
            }
            queue->items = items;
            queue->size = size;
        }
    }
    Py_INCREF(o);
    queue->items[queue->tail++] = o;
    return 0;
}

static void release(Queue *queue) {
    for (Py_ssize_t i = queue->head; i < queue->tail; i++) Py_DECREF(queue->items[i]);
    PyMem_Free(queue->items);
    queue->items = NULL;
    queue->head = queue->tail = queue->size = 0;
}

/* --- flow ----------------------------------------------------------------------------------------- */

PyDoc_STRVAR(flow_doc,
             "flow(pending, reached, max_flow, settled, cancelled, same, /)\n\n"
             "_Search._flow's loop: places every change of reach in ``pending`` (emptied), appends each node\n"
             "whose reach was 0 to ``reached``, and returns the frontier leaves whose reach changed, in order;\n"
             "None when the changes went round more than ``max_flow`` times (the caller then retraces).");

static PyObject *flow(PyObject *self, PyObject *args) {
    PyObject *pending, *reached;
    Py_ssize_t max_flow;
    double settled, cancelled, same;
    if (!PyArg_ParseTuple(args, "O!O!nddd", &PyDict_Type, &pending, &PyList_Type, &reached, &max_flow, &settled,
                          &cancelled, &same))
        return NULL;
    Queue queue = {0};
    PyObject *tips = PyDict_New(), *key, *value, *node = NULL;
    Py_ssize_t position = 0;
    if (tips == NULL) return NULL;
    while (PyDict_Next(pending, &position, &key, &value))
        if (!is_node(key) || push(&queue, key) < 0) goto fail;
    for (Py_ssize_t step = 0; step < max_flow; step++) {
        if (queue.head == queue.tail) {
            release(&queue);
            PyObject *out = PyDict_Keys(tips);
            Py_DECREF(tips);
            return out;
        }
        node = queue.items[queue.head++]; /* owned */
        double delta, reach, back;
        PyObject *change = PyDict_GetItemWithError(pending, node);
        if (change == NULL) {
            if (!PyErr_Occurred()) PyErr_SetString(PyExc_KeyError, "flow: a queued node without a change");
            goto fail;
        }
        if (to_double(change, &delta) < 0 || PyDict_DelItem(pending, node) < 0) goto fail;
        if (field_double(node, off_reach, &reach) < 0) goto fail;
        if (reach == 0.0 && PyList_Append(reached, node) < 0) goto fail;
        reach += delta;
        if (delta < 0.0 && fabs(reach) <= cancelled * -delta) reach = 0.0;
        if (put(node, off_reach, PyFloat_FromDouble(reach)) < 0) goto fail;
        PyObject *leaf = field(node, off_leaf);
        if (leaf == NULL) goto fail;
        if (leaf == frontier) {
            if (PyDict_SetItem(tips, node, Py_None) < 0) goto fail;
            Py_CLEAR(node);
            continue;
        }
        Py_ssize_t best;
        if (leaf != Py_None || field_index(node, off_best, &best) < 0 || best < 0 ||
            fabs(delta) <= settled * fabs(reach)) {
            if (PyErr_Occurred()) goto fail;
            Py_CLEAR(node);
            continue;
        }
        PyObject *exits = field(node, off_exits), *exit, *back_obj, *others;
        if (exits == NULL || (exit = list_item(exits, best, "exits")) == NULL ||
            pair(exit, &back_obj, &others, "an exit") < 0 || to_double(back_obj, &back) < 0)
            goto fail;
        if (back >= 1.0 - same) {
            Py_CLEAR(node);
            continue;
        }
        if (back > 0.0) {
            double extra = delta * back / (1.0 - back);
            if (put(node, off_reach, PyFloat_FromDouble(reach + extra)) < 0) goto fail;
            delta += extra;
        }
        if (!PyList_Check(others)) {
            PyErr_SetString(PyExc_TypeError, "an exit's branches are not a list");
            goto fail;
        }
        for (Py_ssize_t i = 0; i < PyList_GET_SIZE(others); i++) {
            PyObject *p_obj, *child;
            double p;
            if (pair(PyList_GET_ITEM(others, i), &p_obj, &child, "a branch") < 0 || to_double(p_obj, &p) < 0) goto fail;
            if (!is_node(child)) goto fail;
            PyObject *had = PyDict_GetItemWithError(pending, child);
            if (had != NULL) {
                double before;
                if (to_double(had, &before) < 0) goto fail;
                PyObject *sum = PyFloat_FromDouble(before + delta * p);
                if (sum == NULL || PyDict_SetItem(pending, child, sum) < 0) {
                    Py_XDECREF(sum);
                    goto fail;
                }
                Py_DECREF(sum);
            } else {
                if (PyErr_Occurred()) goto fail;
                PyObject *part = PyFloat_FromDouble(delta * p);
                if (part == NULL || PyDict_SetItem(pending, child, part) < 0) {
                    Py_XDECREF(part);
                    goto fail;
                }
                Py_DECREF(part);
                if (push(&queue, child) < 0) goto fail;
            }
        }
        Py_CLEAR(node);
    }
    release(&queue);
    Py_DECREF(tips);
    Py_RETURN_NONE;
fail:
    Py_XDECREF(node);
    release(&queue);
    Py_DECREF(tips);
    return NULL;
}

/* --- reroute ------------------------------------------------------------------------------------- */

/* pending[child] = pending.get(child, 0.0) + sign * reach * p for each (p, observation, child) of ``branches`` */
static int move_reach(PyObject *pending, PyObject *branches, double reach, int sign) {
    if (!PyList_Check(branches)) {
        PyErr_SetString(PyExc_TypeError, "an action's branches are not a list");
        return -1;
    }
    for (Py_ssize_t i = 0; i < PyList_GET_SIZE(branches); i++) {
        PyObject *branch = PyList_GET_ITEM(branches, i);
        if (!PyTuple_Check(branch) || PyTuple_GET_SIZE(branch) != 3) {
            PyErr_SetString(PyExc_TypeError, "a branch is not (probability, observation, node)");
            return -1;
        }
        PyObject *child = PyTuple_GET_ITEM(branch, 2);
        double p, before = 0.0;
        if (to_double(PyTuple_GET_ITEM(branch, 0), &p) < 0 || !is_node(child)) return -1;
        PyObject *had = PyDict_GetItemWithError(pending, child);
        if (had == NULL && PyErr_Occurred()) return -1;
        if (had != NULL && to_double(had, &before) < 0) return -1;
        PyObject *sum = PyFloat_FromDouble(sign > 0 ? before + reach * p : before - reach * p);
        if (sum == NULL) return -1;
        int failed = PyDict_SetItem(pending, child, sum);
        Py_DECREF(sum);
        if (failed < 0) return -1;
    }
    return 0;
}

PyDoc_STRVAR(reroute_doc,
             "reroute(changed, /)\n\n"
             "_Search._reroute's loop: for each node of ``changed`` (node -> the best action it had) whose best\n"
             "action is another now and whose reach is not 0, its reach taken off the old action's branches and\n"
             "put on the new one's. Returns the changes of reach by node, in the order they were first made.");

static PyObject *reroute(PyObject *self, PyObject *args) {
    PyObject *changed, *node, *old_obj;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &changed)) return NULL;
    PyObject *pending = PyDict_New();
    if (pending == NULL) return NULL;
    Py_ssize_t position = 0;
    while (PyDict_Next(changed, &position, &node, &old_obj)) {
        Py_ssize_t old, best;
        double reach;
        if (!is_node(node) || field_double(node, off_reach, &reach) < 0 || field_index(node, off_best, &best) < 0)
            goto fail;
        if ((old = PyLong_AsSsize_t(old_obj)) == -1 && PyErr_Occurred()) goto fail;
        if (best == old || reach == 0.0) continue;
        PyObject *children = field(node, off_children);
        if (children == NULL) goto fail;
        if (!PyDict_Check(children)) {
            PyErr_SetString(PyExc_TypeError, "a node's children are not a dict");
            goto fail;
        }
        if (old >= 0) {
            PyObject *branches = PyDict_GetItemWithError(children, old_obj);
            if (branches == NULL) {
                if (!PyErr_Occurred()) PyErr_SetObject(PyExc_KeyError, old_obj);
                goto fail;
            }
            if (move_reach(pending, branches, reach, -1) < 0) goto fail;
        }
        if (best >= 0) {
            PyObject *best_obj = field(node, off_best), *branches;
            if (best_obj == NULL) goto fail;
            if ((branches = PyDict_GetItemWithError(children, best_obj)) == NULL) {
                if (!PyErr_Occurred()) PyErr_SetObject(PyExc_KeyError, best_obj);
                goto fail;
            }
            if (move_reach(pending, branches, reach, 1) < 0) goto fail;
        }
    }
    return pending;
fail:
    Py_DECREF(pending);
    return NULL;
}

/* --- revise --------------------------------------------------------------------------------------- */

/* add ``action`` to the node's stale actions (a new set when it has none) */
static int mark_stale(PyObject *node, PyObject *action) {
    PyObject *stale = field(node, off_stale);
    if (stale == NULL) return -1;
    if (stale == Py_None) {
        PyObject *fresh = PySet_New(NULL);
        if (fresh == NULL || PySet_Add(fresh, action) < 0) {
            Py_XDECREF(fresh);
            return -1;
        }
        return put(node, off_stale, fresh);
    }
    if (!PySet_Check(stale)) {
        PyErr_SetString(PyExc_TypeError, "a node's stale actions are not a set");
        return -1;
    }
    return PySet_Add(stale, action);
}

static int enqueue(Queue *pending, PyObject *queued, PyObject *node) {
    if (PySet_Add(queued, node) < 0) return -1;
    return push(pending, node);
}

/* _Search._pass_on */
static int pass_on(PyObject *node, int rose, Queue *pending, PyObject *queued) {
    PyObject *parents = field(node, off_parents);
    if (parents == NULL) return -1;
    if (!PyList_Check(parents)) {
        PyErr_SetString(PyExc_TypeError, "a node's parents are not a list");
        return -1;
    }
    for (Py_ssize_t i = 0; i < PyList_GET_SIZE(parents); i++) {
        PyObject *parent, *action_obj;
        Py_ssize_t action, parent_best;
        if (pair(PyList_GET_ITEM(parents, i), &parent, &action_obj, "a parent") < 0 || !is_node(parent)) return -1;
        if ((action = PyLong_AsSsize_t(action_obj)) == -1 && PyErr_Occurred()) return -1;
        if (mark_stale(parent, action_obj) < 0 || field_index(parent, off_best, &parent_best) < 0) return -1;
        if (rose && action != parent_best) continue;
        int in = PySet_Contains(queued, parent);
        if (in < 0 || (!in && enqueue(pending, queued, parent) < 0)) return -1;
    }
    return 0;
}

PyDoc_STRVAR(revise_doc,
             "revise(node, costs, dead_ends, max_revisions, trap_check, same, /)\n\n"
             "_Search._revise's loop: Bellman backups from ``node`` up; ``dead_ends()`` is called after\n"
             "``trap_check`` backups. Returns the nodes whose best action changed, each with the one it had.");

static PyObject *revise(PyObject *self, PyObject *args) {
    PyObject *start, *costs_list, *dead_ends;
    Py_ssize_t max_revisions, trap_check;
    double same;
    if (!PyArg_ParseTuple(args, "OO!Onnd", &start, &PyList_Type, &costs_list, &dead_ends, &max_revisions, &trap_check,
                          &same))
        return NULL;
    if (!is_node(start)) return NULL;
    Py_ssize_t n_actions = PyList_GET_SIZE(costs_list);
    double *costs = PyMem_Malloc((n_actions ? n_actions : 1) * sizeof(double));
    if (costs == NULL) return PyErr_NoMemory();
    Queue pending = {0};
    PyObject *changed = PyDict_New(), *queued = PySet_New(NULL), *current = NULL;
    if (changed == NULL || queued == NULL) goto fail;
    for (Py_ssize_t a = 0; a < n_actions; a++)
        if (to_double(PyList_GET_ITEM(costs_list, a), &costs[a]) < 0) goto fail;
    if (enqueue(&pending, queued, start) < 0) goto fail;
    int first = 1; /* the expanded node's value went from the estimate to its backup: always passed on */
    for (Py_ssize_t backups = 0; backups < max_revisions; backups++) {
        if (pending.head == pending.tail) break;
        if (backups == trap_check) {
            PyObject *dead = PyObject_CallNoArgs(dead_ends);
            if (dead == NULL) goto fail;
            if (!PyList_Check(dead)) {
                Py_DECREF(dead);
                PyErr_SetString(PyExc_TypeError, "dead_ends() did not return a list");
                goto fail;
            }
            for (Py_ssize_t i = 0; i < PyList_GET_SIZE(dead); i++) {
                PyObject *node = PyList_GET_ITEM(dead, i), *best;
                if (!is_node(node) || (best = field(node, off_best)) == NULL ||
                    PyDict_SetDefault(changed, node, best) == NULL || put(node, off_best, PyLong_FromLong(-1)) < 0 ||
                    put(node, off_value, PyFloat_FromDouble(INFINITY)) < 0 || pass_on(node, 1, &pending, queued) < 0) {
                    Py_DECREF(dead);
                    goto fail;
                }
            }
            Py_DECREF(dead);
        }
        current = pending.items[pending.head++]; /* owned */
        if (PySet_Discard(queued, current) < 0) goto fail;
        PyObject *q = field(current, off_q), *stale = field(current, off_stale);
        if (q == NULL || stale == NULL) goto fail;
        if (!PyList_Check(q)) {
            PyErr_SetString(PyExc_TypeError, "a node's Q values are not a list");
            goto fail;
        }
        if (stale != Py_None && PySet_Check(stale) && PySet_GET_SIZE(stale) > 0) {
            PyObject *exits = field(current, off_exits), *iterator, *action_obj;
            if (exits == NULL || (iterator = PyObject_GetIter(stale)) == NULL) goto fail;
            while ((action_obj = PyIter_Next(iterator)) != NULL) {
                Py_ssize_t action = PyLong_AsSsize_t(action_obj);
                Py_DECREF(action_obj);
                double value;
                if ((action == -1 && PyErr_Occurred()) || action < 0 || action >= n_actions ||
                    action >= PyList_GET_SIZE(q) || exit_q(exits, action, costs[action], same, &value) < 0) {
                    if (!PyErr_Occurred()) PyErr_SetString(PyExc_IndexError, "a stale action out of range");
                    Py_DECREF(iterator);
                    goto fail;
                }
                PyObject *f = PyFloat_FromDouble(value);
                if (f == NULL || PyList_SetItem(q, action, f) < 0) {
                    Py_DECREF(iterator);
                    goto fail;
                }
            }
            Py_DECREF(iterator);
            if (PyErr_Occurred()) goto fail;
            Py_INCREF(Py_None);
            if (put(current, off_stale, Py_None) < 0) goto fail;
        } else if (stale != Py_None && !PySet_Check(stale)) {
            PyErr_SetString(PyExc_TypeError, "a node's stale actions are not a set");
            goto fail;
        }
        /* min(q) (the first of equal ones), and its index unless it is infinite */
        Py_ssize_t n = PyList_GET_SIZE(q), best = -1;
        double value = INFINITY;
        if (n > 0) {
            if (to_double(PyList_GET_ITEM(q, 0), &value) < 0) goto fail;
            for (Py_ssize_t i = 1; i < n; i++) {
                double v;
                if (to_double(PyList_GET_ITEM(q, i), &v) < 0) goto fail;
                if (v < value) value = v;
            }
            if (value < INFINITY) {
                for (Py_ssize_t i = 0; i < n; i++) {
                    double v;
                    if (to_double(PyList_GET_ITEM(q, i), &v) < 0) goto fail;
                    if (v == value) {
                        best = i;
                        break;
                    }
                }
            }
        }
        Py_ssize_t old_best;
        double old_value;
        if (field_index(current, off_best, &old_best) < 0 || field_double(current, off_value, &old_value) < 0) goto fail;
        if (best != old_best && PyDict_SetDefault(changed, current, field(current, off_best)) == NULL) goto fail;
        if (put(current, off_best, PyLong_FromSsize_t(best)) < 0) goto fail;
        int settled = value == old_value || fabs(value - old_value) <= same * fmax(1.0, fabs(value));
        if (settled && !first) {
            Py_CLEAR(current);
            continue;
        }
        first = 0;
        int rose = value > old_value;
        if (put(current, off_value, PyFloat_FromDouble(value)) < 0) goto fail;
        PyObject *parents = field(current, off_parents);
        if (parents == NULL) goto fail;
        if (!PyList_Check(parents)) {
            PyErr_SetString(PyExc_TypeError, "a node's parents are not a list");
            goto fail;
        }
        for (Py_ssize_t i = 0; i < PyList_GET_SIZE(parents); i++) {
            PyObject *parent, *action_obj;
            Py_ssize_t action, parent_best;
            if (pair(PyList_GET_ITEM(parents, i), &parent, &action_obj, "a parent") < 0 || !is_node(parent)) goto fail;
            if ((action = PyLong_AsSsize_t(action_obj)) == -1 && PyErr_Occurred()) goto fail;
            int in = PySet_Contains(queued, parent);
            if (in < 0 || field_index(parent, off_best, &parent_best) < 0) goto fail;
            if (in || rose || action == parent_best) {
                if (mark_stale(parent, action_obj) < 0) goto fail;
                if (!in && (!rose || action == parent_best) && enqueue(&pending, queued, parent) < 0) goto fail;
                continue;
            }
            /* the value fell under an action that is not the parent's best: recomputed here, the parent
             * is backed up only if that action may now be its best */
            PyObject *parent_exits = field(parent, off_exits), *parent_q = field(parent, off_q), *parent_stale;
            double fell, cheapest = INFINITY;
            if (parent_exits == NULL || parent_q == NULL || action < 0 || action >= n_actions) {
                if (!PyErr_Occurred()) PyErr_SetString(PyExc_IndexError, "a parent's action out of range");
                goto fail;
            }
            if (exit_q(parent_exits, action, costs[action], same, &fell) < 0) goto fail;
            if (!PyList_Check(parent_q) || action >= PyList_GET_SIZE(parent_q)) {
                PyErr_SetString(PyExc_IndexError, "a parent's Q values do not hold the action");
                goto fail;
            }
            PyObject *f = PyFloat_FromDouble(fell);
            if (f == NULL || PyList_SetItem(parent_q, action, f) < 0) goto fail;
            if ((parent_stale = field(parent, off_stale)) == NULL) goto fail;
            if (parent_stale != Py_None && (!PySet_Check(parent_stale) || PySet_Discard(parent_stale, action_obj) < 0)) {
                if (!PyErr_Occurred()) PyErr_SetString(PyExc_TypeError, "a node's stale actions are not a set");
                goto fail;
            }
            if (parent_best >= 0) {
                PyObject *own = list_item(parent_q, parent_best, "a parent's Q values");
                if (own == NULL || to_double(own, &cheapest) < 0) goto fail;
            }
            if ((fell < cheapest || (fell == cheapest && action < parent_best)) &&
                enqueue(&pending, queued, parent) < 0)
                goto fail;
        }
        Py_CLEAR(current);
    }
    release(&pending);
    Py_DECREF(queued);
    PyMem_Free(costs);
    return changed;
fail:
    Py_XDECREF(current);
    release(&pending);
    Py_XDECREF(queued);
    Py_XDECREF(changed);
    PyMem_Free(costs);
    return NULL;
}

static PyMethodDef methods[] = {
    {"setup", setup, METH_VARARGS, "setup(node_class, frontier, /): the node class's slots and the frontier's kind."},
    {"revise", revise, METH_VARARGS, revise_doc},
    {"flow", flow, METH_VARARGS, flow_doc},
    {"reroute", reroute, METH_VARARGS, reroute_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_lao", "LAO*'s bookkeeping: contingent.py's backups and flow of reach (see _lao.c).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__lao(void) { return PyModule_Create(&module); }
