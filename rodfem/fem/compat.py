"""Everything that differs between DOLFINx versions, in one place.

rodfem is developed on Debian 12's DOLFINx 0.5.2 (UFL 2022.2, ffcx 0.5,
petsc4py 3.18).  The branches for newer versions (UFL >= 2023.2 with
``basix.ufl`` elements, ``fem.functionspace``, ``u.x.petsc_vec``,
``form_compiler_options``) follow the 0.9/0.10 sources and are detected by
feature, never by version string.  No other module may test for versions.
"""
import inspect

import ufl
from dolfinx import __version__ as dolfinx_version  # noqa: F401  (re-exported)
from dolfinx import fem

LEGACY_UFL = hasattr(ufl, "FiniteElement")

_FAMILY = {"P": "Lagrange", "DG": "DG"}


def element(family, mesh, degree, shape=()):
    """A scalar or vector element: family 'P' (continuous) or 'DG'."""
    fam = _FAMILY.get(family, family)
    if not LEGACY_UFL:  # pragma: no cover - DOLFINx >= 0.7
        import basix.ufl
        return basix.ufl.element(fam, mesh.basix_cell(), degree, shape=shape or None)
    if not shape:
        return ufl.FiniteElement(fam, mesh.ufl_cell(), degree)
    return ufl.VectorElement(fam, mesh.ufl_cell(), degree, dim=shape[0])


def mixed_element(elements):
    if not LEGACY_UFL:  # pragma: no cover
        import basix.ufl
        return basix.ufl.mixed_element(elements)
    return ufl.MixedElement(elements)


def abstract_mesh(cell="interval", gdim=1):
    """A UFL mesh without a DOLFINx mesh behind it (for UFL expressions in x alone): affine
    Lagrange coordinates on `cell` in `gdim` dimensions."""
    if not LEGACY_UFL:  # pragma: no cover
        import basix.ufl
        return ufl.Mesh(basix.ufl.element("Lagrange", cell, 1, shape=(gdim,)))
    return ufl.Mesh(ufl.VectorElement("Lagrange", getattr(ufl, cell), 1, dim=gdim))


def functionspace(mesh, el):
    if hasattr(fem, "functionspace"):  # pragma: no cover
        return fem.functionspace(mesh, el)
    return fem.FunctionSpace(mesh, el)


def settle_coordinate_element(mesh):
    """Give the mesh's coordinate element the equispaced variant ffcx 0.5 gives it when it first
    compiles a form on the mesh.  ffcx replaces the element in place, which changes the signature
    (the JIT cache key) of an expression compiled on that mesh afterwards: a cold run (forms
    compiled) and a warm run (forms loaded) would key the same expression differently and the
    warm run compile it again.  Settled up front, the key is the same in both."""
    domain = mesh.ufl_domain()
    el = getattr(domain, "_ufl_coordinate_element", None)
    sub = getattr(el, "_sub_element", None)
    if LEGACY_UFL and sub is not None and getattr(sub, "_variant", "") is None:
        equispaced = ufl.FiniteElement(el.family(), el.cell(), el.degree(), el.quadrature_scheme(),
                                       variant="equispaced")
        domain._ufl_coordinate_element = ufl.VectorElement(equispaced)


def dofmap_array(dofmap):
    """The cell-to-dof array of a dofmap, one row per cell (0.5: an AdjacencyList from
    ``dofmap.list()``; 0.9: a two-dimensional array, ``dofmap.map()`` of the C++ dofmap or the
    ``list`` property of the Python one)."""
    import numpy as np
    if hasattr(dofmap, "map"):  # pragma: no cover - DOLFINx >= 0.7
        return np.asarray(dofmap.map())
    lst = dofmap.list() if callable(dofmap.list) else dofmap.list
    return _adjacency_array(lst) if hasattr(lst, "offsets") else np.asarray(lst)


def _adjacency_array(adj):
    """An AdjacencyList of equal-length rows as a two-dimensional array."""
    import numpy as np
    n = int(adj.offsets[1] - adj.offsets[0]) if len(adj.offsets) > 1 else 0
    return np.asarray(adj.array).reshape(-1, n) if n else np.zeros((0, 0), np.int32)


def geometry_dofmap(mesh):
    """The cell-to-geometry-node array of a mesh, one row per cell (0.5: an AdjacencyList;
    0.9: a two-dimensional array)."""
    import numpy as np
    g = mesh.geometry.dofmap
    if hasattr(g, "offsets"):
        return _adjacency_array(g)
    return np.asarray(g)  # pragma: no cover - DOLFINx >= 0.7


def cpp_form(compiled):
    """The C++ form behind a compiled form (0.5: the form is its own C++ object; 0.9: ``_cpp_object``)."""
    return getattr(compiled, "_cpp_object", compiled)


def integral_ids(compiled, itype):
    """The subdomain ids of the integrals of type `itype` of a compiled form."""
    return list(cpp_form(compiled).integral_ids(itype))


def integration_domain(compiled, itype, i):
    """The entities integral (itype, i) runs over: cells, or (cell, local facet) pairs flattened."""
    return cpp_form(compiled).domains(itype, i)


def kernel(compiled, itype, i):
    """The ufcx integral (its ``tabulate_tensor_float64`` is the element kernel) of integral
    (itype, i): 0.5 keeps per-type arrays (``integrals(code)``, ``integral_ids(code)``); ufcx 0.9 one
    flat array ``form_integrals`` with ``form_integral_ids`` and offsets per type.  The kernel's
    signature is the same in both: (A, w, c, coordinate_dofs, entity_local_index, permutation)."""
    from dolfinx.fem import IntegralType
    code = {IntegralType.cell: 0, IntegralType.exterior_facet: 1, IntegralType.interior_facet: 2}[itype]
    ufcx = compiled.ufcx_form
    if hasattr(ufcx, "form_integrals"):  # pragma: no cover - ufcx >= 0.7
        lo, hi = ufcx.form_integral_offsets[code], ufcx.form_integral_offsets[code + 1]
        ids = [ufcx.form_integral_ids[k] for k in range(lo, hi)]
        return ufcx.form_integrals[lo + ids.index(i)]
    ids = [ufcx.integral_ids(code)[k] for k in range(ufcx.num_integrals(code))]
    return ufcx.integrals(code)[ids.index(i)]


def pack_coefficients(compiled):
    """{(itype, id): coefficients packed per entity} of a compiled form, as its kernels take them."""
    from dolfinx import cpp
    return cpp.fem.pack_coefficients(cpp_form(compiled))


def pack_constants(compiled):
    from dolfinx import cpp
    return cpp.fem.pack_constants(cpp_form(compiled))


def petsc_vec(u):
    """The PETSc vector behind a dolfinx Function."""
    return u.x.petsc_vec if hasattr(u.x, "petsc_vec") else u.vector


def eval_expression(expr, mesh, cells):
    """A compiled fem.Expression evaluated on `cells` (0.5: ``eval(cells)``; 0.9: ``eval(mesh, cells)``)."""
    first = next(iter(inspect.signature(expr.eval).parameters))
    if first == "mesh":  # pragma: no cover - DOLFINx >= 0.8
        return expr.eval(mesh, cells)
    return expr.eval(cells)


def form(f):
    """Compile a UFL form (JIT-cached on disk, so a second run does not recompile)."""
    return fem.form(f)


def form_twin(compiled, ufl_form, swap, mesh):
    """The compiled form `compiled` (of the UFL form `ufl_form`) on other objects: each coefficient,
    constant, argument space and subdomain tag o of `ufl_form` replaced by swap.get(id(o), o), on
    `mesh`.  The same kernels (no UFL, no JIT): for a form equal to `ufl_form` up to those names."""
    from dolfinx import cpp

    def to(o):
        return swap.get(id(o), o)
    ufcx = compiled.ufcx_form
    original = ufl_form.coefficients()
    positions = getattr(ufcx, "original_coefficient_position", None)
    if positions is None:   # pragma: no cover - DOLFINx >= 0.8
        return _form_twin_nanobind(compiled, ufl_form, to, mesh)
    coefficients = [to(original[positions[i]])._cpp_object for i in range(ufcx.num_coefficients)]
    constants = [to(c)._cpp_object for c in ufl_form.constants()]
    spaces = [to(a.ufl_function_space())._cpp_object for a in ufl_form.arguments()]
    data, = list(ufl_form.subdomain_data().values())
    kinds = {"cell": cpp.fem.IntegralType.cell, "exterior_facet": cpp.fem.IntegralType.exterior_facet,
             "interior_facet": cpp.fem.IntegralType.interior_facet, "vertex": cpp.fem.IntegralType.vertex}
    subdomains = {t: to(data.get(name)) for name, t in kinds.items()}
    return type(compiled)(ufcx, spaces, coefficients, constants, subdomains, mesh.ufl_domain().ufl_cargo(), _ffi(),
                          compiled.code)


def _form_twin_nanobind(compiled, ufl_form, to, mesh):   # pragma: no cover - DOLFINx >= 0.8
    """form_twin for DOLFINx 0.8-0.9, after dolfinx.fem.forms.form's `_form`: the C++ form takes
    the integration entities of each subdomain id (not the tags) and the entity maps."""
    import itertools

    from dolfinx.fem import forms as dforms
    ufcx = compiled.ufcx_form
    original = ufl_form.coefficients()
    coefficients = [to(original[ufcx.original_coefficient_positions[i]])._cpp_object
                    for i in range(ufcx.num_coefficients)]
    constants = [to(c)._cpp_object for c in ufl_form.constants()]
    spaces = [to(a.ufl_function_space())._cpp_object for a in ufl_form.arguments()]
    data, = list(ufl_form.subdomain_data().values())
    ids = {kind: [] for kind in data}
    for integral in ufl_form.integrals():
        if integral.subdomain_data() is not None and integral.subdomain_id() != "everywhere":
            sid = integral.subdomain_id()
            ids[integral.integral_type()].append([i for i in sid if i != "everywhere"]
                                                 if isinstance(sid, tuple) else [sid])
    subdomains = {dforms._ufl_to_dolfinx_domain[kind]: dforms.get_integration_domains(
        dforms._ufl_to_dolfinx_domain[kind], to(tags[0]), sorted(itertools.chain.from_iterable(ids[kind])))
        for kind, tags in data.items()}
    cpp_form = type(compiled._cpp_object)(_ffi().cast("uintptr_t", _ffi().addressof(ufcx)), spaces, coefficients,
                                          constants, subdomains, {}, mesh.ufl_domain().ufl_cargo())
    return type(compiled)(cpp_form, ufcx, compiled.code, compiled.module)


def _ffi():
    """One cffi.FFI for the casts of the twins (it parses a type once)."""
    global _FFI
    if _FFI is None:
        import cffi
        _FFI = cffi.FFI()
    return _FFI


_FFI = None


def interpolate(f, u):
    """f <- u interpolated on every cell (u: a fem.Expression or a callable x -> values): DOLFINx's
    Function.interpolate without its dispatch made anew at each call (0.5.2: ~0.2 ms)."""
    import numpy as np
    from dolfinx import cpp
    V = f.function_space
    inner = getattr(V.mesh, "_mesh", None)
    if inner is None or not hasattr(cpp.fem, "interpolation_coords"):   # pragma: no cover - another DOLFINx
        return f.interpolate(u)
    imap = V.mesh.topology.index_map(V.mesh.topology.dim)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    if isinstance(u, fem.Expression):
        f._cpp_object.interpolate(u._cpp_object, cells)
    else:
        x = cpp.fem.interpolation_coords(V.element, inner, cells)
        f._cpp_object.interpolate(np.asarray(u(x), dtype=f.x.array.dtype), cells)


def expression_twin(expression, swap, mesh):
    """The compiled fem.Expression `expression` with each coefficient and constant o of its UFL replaced
    by swap.get(id(o), o), on `mesh`: the same kernel (no JIT), for the expression equal to it up to those names."""
    import copy

    from dolfinx import cpp

    def to(o):
        return swap.get(id(o), o)
    ufcx, expr = expression._ufcx_expression, expression._ufl_expression
    if not hasattr(expression, "_rodfem_terminals"):   # (its coefficients in the kernel's order, its constants)
        original = ufl.algorithms.extract_coefficients(expr)
        expression._rodfem_terminals = ([original[ufcx.original_coefficient_positions[i]]
                                         for i in range(ufcx.num_coefficients)],
                                        ufl.algorithms.analysis.extract_constants(expr))
    coefficients = [to(c)._cpp_object for c in expression._rodfem_terminals[0]]
    constants = [to(c)._cpp_object for c in expression._rodfem_terminals[1]]
    twin = copy.copy(expression)
    create = cpp.fem.create_expression_float64
    on_mesh = ((mesh.ufl_domain().ufl_cargo(),) if "mesh:" in (create.__doc__ or "")
               else ())   # DOLFINx 0.5 binds the expression to a mesh; 0.9 does not
    twin._cpp_object = create(_ffi().cast("uintptr_t", _ffi().addressof(ufcx)), coefficients, constants,
                              *on_mesh, expression.argument_function_space)
    return twin


def dirichlet_values(bc):
    """The array of a DirichletBC's values Function, local and with ghosts (`bc.value` in 0.5, `bc.g` later)."""
    return (bc.g if hasattr(bc, "g") else bc.value).x.array


def create_vector(compiled_form):
    from dolfinx.fem import petsc
    first = next(iter(inspect.signature(petsc.create_vector).parameters))
    if first == "V":  # pragma: no cover - DOLFINx 0.10
        return petsc.create_vector(compiled_form.function_spaces[0])
    return petsc.create_vector(compiled_form)


def create_block_matrix(comm, diagonal):
    """A PETSc matrix for the block-diagonal system of the compiled forms `diagonal`, each on
    its own mesh (DOLFINx 0.5's create_matrix_block builds every block's pattern on the FIRST
    block's mesh, which breaks for blocks on different meshes)."""
    from dolfinx import cpp
    maps = [(a.function_spaces[0].dofmap.index_map, a.function_spaces[0].dofmap.index_map_bs) for a in diagonal]
    patterns = []
    for i, a in enumerate(diagonal):
        row = []
        for j, (imap, bs) in enumerate(maps):
            if i == j:
                V = a.function_spaces[0]
                sp = cpp.fem.create_sparsity_pattern(V.mesh.topology, [V.dofmap] * 2, set(a.integral_types))
            else:
                sp = cpp.la.SparsityPattern(comm, [maps[i][0], imap], [maps[i][1], bs])
            row.append(sp)
        patterns.append(row)
    pattern = cpp.la.SparsityPattern(comm, patterns, [maps, maps], [[b for _, b in maps]] * 2)
    pattern.assemble()
    A = cpp.la.petsc.create_matrix(comm, pattern)
    # The local numbering the block assembly uses is field by field (owned_0, ghosts_0, owned_1, ...):
    # attach that local-to-global map (as DOLFINx's create_matrix_block does).
    from petsc4py import PETSc
    lg = PETSc.LGMap().create(block_local_to_global(comm, maps), comm=PETSc.COMM_SELF)
    A.setLGMap(lg, lg)
    return A


def block_local_to_global(comm, maps):
    """Global indices of the block layout (x_1, ..., x_k) for the local numbering field by field."""
    import numpy as np
    sizes = np.array([imap.size_local * bs for imap, bs in maps], dtype=np.int64)
    all_sizes = np.array(comm.allgather(sizes))                     # [rank, field]
    rank_offset = np.concatenate([[0], np.cumsum(all_sizes.sum(axis=1))])
    field_offset = np.concatenate([np.zeros((len(all_sizes), 1), np.int64), np.cumsum(all_sizes, axis=1)], axis=1)
    out = []
    for f, (imap, bs) in enumerate(maps):
        out.append(rank_offset[comm.rank] + field_offset[comm.rank, f] + np.arange(sizes[f]))
        ghosts, owners = np.asarray(imap.ghosts, dtype=np.int64), np.asarray(imap.owners)
        starts = np.array(comm.allgather(imap.local_range[0]), dtype=np.int64)
        base = rank_offset[owners] + field_offset[owners, f] + (ghosts - starts[owners]) * bs
        out.append((base[:, None] + np.arange(bs)[None, :]).ravel())
    return np.concatenate(out).astype(PETSc_int())


def PETSc_int():
    from petsc4py import PETSc
    return PETSc.IntType


def form_comm(ufl_form):
    """The communicator of the mesh a UFL form is defined on."""
    return ufl_form.ufl_domain().ufl_cargo().comm


def jit_cache_dir():
    """The directory DOLFINx's JIT compiles into ($XDG_CACHE_HOME/fenics, default ~/.cache/fenics)."""
    from pathlib import Path

    from dolfinx import jit
    options = jit.get_options() if hasattr(jit, "get_options") else jit.get_parameters()
    return Path(options["cache_dir"])


def hook_jit_compilers(around):
    """Replace each of ffcx's JIT entry points (``codegeneration.jit.compile_forms``,
    ``compile_expressions``, and 0.5's ``compile_elements``, ``compile_coordinate_maps``) by
    around(entry_point); DOLFINx calls them through the module, so every compilation goes through
    the wrappers.  Returns the names replaced."""
    import ffcx.codegeneration.jit as ffcx_jit
    names = []
    for name in ("compile_forms", "compile_expressions", "compile_elements", "compile_coordinate_maps"):
        entry = getattr(ffcx_jit, name, None)
        if entry is None:
            continue
        entry = getattr(entry, "rodfem_hook", entry)
        wrapped = around(entry)
        wrapped.rodfem_hook = entry
        setattr(ffcx_jit, name, wrapped)
        names.append(name)
    return names


def hook_jit_lookup(before):
    """Have ffcx call before(module_name, cache_dir) each time it looks a module up in the JIT cache
    (where it either loads a compiled module or claims it and compiles): ffcx's
    ``codegeneration.jit.get_cached_module``.  A module found once is remembered for the process
    (ffcx lists the whole cache directory at every lookup: with thousands of modules cached that was
    18 ms per body built, issue 26).  False if this ffcx has no such function."""
    import functools

    import ffcx.codegeneration.jit as ffcx_jit
    lookup = getattr(ffcx_jit, "get_cached_module", None)
    if lookup is None:   # pragma: no cover - another ffcx
        return False
    if getattr(lookup, "rodfem_hook", None) is not None:
        lookup = lookup.rodfem_hook

    loaded = {}   # modules this process has loaded: ffcx would list the cache directory again for each

    @functools.wraps(lookup)
    def hooked(module_name, object_names, cache_dir, *args, **kwargs):
        key = (module_name, tuple(object_names), str(cache_dir))
        if key in loaded:   # (the same compiled objects: a module is loaded once per process anyway)
            return loaded[key]
        before(module_name, cache_dir)
        found = lookup(module_name, object_names, cache_dir, *args, **kwargs)
        if found[0] is not None:
            loaded[key] = found
        return found
    hooked.rodfem_hook = lookup
    ffcx_jit.get_cached_module = hooked
    return True
