"""The 256-channel cap's neck rows: the electrodes below the head, by the cap's geometry only.

The rule (:data:`validation.real_sep.criteria.NECK_RULE`, fixed before the run that drops
them): register MNE's 10-05 template head (``colin27_1005``: 343 electrode positions on the
Colin27 scalp, with its nasion, preauricular points and inion ``Iz``) to the cap's
triangulated surface by a uniform scale and a translation (the cap's axes kept, as the
criteria keep them), and call the electrodes below the plane through the registered inion
and the two preauricular points the neck rows. Neither the sensor data nor an estimate
enter: only the electrode positions and spharapy's triangulation of them.
"""

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: MNE's 10-05 template head (MNE >= 1.13 names it ``colin27_1005``, earlier
#: ``standard_1005``; the same positions).
TEMPLATE = ("colin27_1005", "standard_1005")
#: Template positions farther than this from the cap's surface after a step are left out of
#: the next (m): the template's face and lowest rows, which the cap does not cover.
TRIM = 0.010
#: Each of the cap's triangles is sampled on a barycentric grid of this step's inverse.
SUBDIVISION = 12
ITERATIONS = 100


@dataclass
class NeckRows:
    """The registration and the rows it finds.

    Attributes
    ----------
    names : list of str
        The neck rows, in the evoked's channel order.
    below : ndarray of bool, shape (n_channels,)
        Below the plane, per channel of the evoked.
    landmarks : dict
        ``"nasion"``, ``"lpa"``, ``"rpa"``, ``"inion"``: the registered template's (m, the
        evoked's frame).
    normal : ndarray, shape (3,)
        The plane's unit normal, pointing up; the plane holds ``landmarks["inion"]``.
    scale : float
        The template's scale onto the cap.
    rms : float
        Root mean square distance (m) of the template positions kept to the cap's surface.
    kept : int
        Template positions within :data:`TRIM` of the surface at the end.
    """

    names: list
    below: np.ndarray
    landmarks: dict
    normal: np.ndarray
    scale: float
    rms: float
    kept: int


def _template():
    import mne

    for name in TEMPLATE:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)  # standard_1005's new name
            try:
                positions = mne.channels.make_standard_montage(name).get_positions()
            except ValueError:
                continue
        return positions
    raise RuntimeError(f"MNE has none of the templates {TEMPLATE}")


def _sphere(points):
    """The algebraic least-squares sphere: centre and radius."""
    A = np.column_stack([2 * points, np.ones(len(points))])
    solution = np.linalg.lstsq(A, (points**2).sum(axis=1), rcond=None)[0]
    centre = solution[:3]
    return centre, float(np.sqrt(solution[3] + centre @ centre))


def _surface(positions, triangles):
    """Points sampled densely on the cap's triangles (about 3 mm apart)."""
    n = SUBDIVISION
    weights = [(i / n, j / n) for i in range(n + 1) for j in range(n + 1 - i)]
    a, b, c = (positions[triangles[:, k]] for k in range(3))
    return np.vstack([(1 - u - v) * a + u * b + v * c for u, v in weights])


def _similarity(P, Q, rotate):
    """Least-squares ``Q ~ scale R P + shift``: R the identity unless ``rotate`` (Umeyama)."""
    if not rotate:
        A = np.zeros((3 * len(P), 4))
        A[:, 0] = P.ravel()
        for axis in range(3):
            A[axis::3, 1 + axis] = 1.0
        solution = np.linalg.lstsq(A, Q.ravel(), rcond=None)[0]
        return float(solution[0]), np.eye(3), solution[1:]
    mp, mq = P.mean(axis=0), Q.mean(axis=0)
    U, S, Vt = np.linalg.svd((Q - mq).T @ (P - mp))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    scale = float(np.trace(np.diag(S) @ D) / ((P - mp) ** 2).sum())
    return scale, R, mq - scale * R @ mp


def register(template_points, surface, *, trim=TRIM, rotate=False):
    """Scale and translation taking the template's points onto the surface (trimmed ICP).

    Starts from the two algebraic spheres (centres matched, radii's ratio), then alternates
    nearest surface points (pairs farther than ``trim`` left out) and the least-squares
    scale and translation for the pairs (and a rotation, with ``rotate``: the rule's
    sensitivity only). Returns ``(transform, rms, kept)``, ``transform(points)`` the
    registered points.
    """
    tree = cKDTree(surface)
    (cs, rs), (ct, rt) = _sphere(surface), _sphere(template_points)
    scale, R, shift = rs / rt, np.eye(3), cs - rs / rt * ct

    def transform(points):
        return scale * np.asarray(points) @ R.T + shift

    for _ in range(ITERATIONS):
        distance, nearest = tree.query(transform(template_points))
        keep = distance < trim
        scale, R, shift = _similarity(template_points[keep], surface[nearest[keep]], rotate)
    distance, _ = tree.query(transform(template_points))
    keep = distance < trim
    return transform, float(np.sqrt((distance[keep] ** 2).mean())), int(keep.sum())


def neck_rows(evoked, triangles, *, trim=TRIM, rotate=False):
    """The cap's electrodes below the plane through the registered inion and preauriculars.

    Parameters
    ----------
    evoked : mne.Evoked
        The 256-channel recording (its positions, m, MNE's head-frame axes).
    triangles : ndarray of int, shape (n_triangles, 3)
        The cap's triangulation, indices into the evoked's channels (spharapy's
        ``trilist``).
    trim, rotate
        The rule's registration (:data:`TRIM`, no rotation); :data:`VARIANTS` holds the
        others its sensitivity is checked with.

    Returns
    -------
    NeckRows
    """
    positions = np.array([ch["loc"][:3] for ch in evoked.info["chs"]])
    template = _template()
    names = list(template["ch_pos"])
    points = np.array([template["ch_pos"][name] for name in names])
    surface = _surface(positions, np.asarray(triangles))
    transform, rms, kept = register(points, surface, trim=trim, rotate=rotate)
    landmarks = {key: transform(template[key]) for key in ("nasion", "lpa", "rpa")}
    landmarks["inion"] = transform(points[names.index("Iz")])
    scale = float(np.linalg.norm(transform(points[1]) - transform(points[0]))) / float(
        np.linalg.norm(points[1] - points[0])
    )
    inion = landmarks["inion"]
    normal = np.cross(landmarks["lpa"] - inion, landmarks["rpa"] - inion)
    normal /= np.linalg.norm(normal) * np.sign(normal[2])
    below = (positions - inion) @ normal < 0
    return NeckRows(
        names=[name for name, b in zip(evoked.ch_names, below, strict=True) if b],
        below=below,
        landmarks=landmarks,
        normal=normal,
        scale=scale,
        rms=rms,
        kept=kept,
    )


#: The rule's two neighbours, written into the rule as its known uncertainty and run after
#: it (observations, not the rule): trimming at 5 mm, and a registration that may turn.
VARIANTS = {"trim 5 mm": dict(trim=0.005), "rotation allowed": dict(rotate=True)}


def sep256_triangles():
    """spharapy's triangulation of the 256-channel cap, 0-based, in the evoked's order."""
    from spharapy import datasets

    triangles = np.asarray(datasets.load_eeg_256_channel_study()["trilist"], dtype=int)
    return triangles - triangles.min()
