"""A Python client of the kinematics service: numpy arrays in and out over the binary transport.

It speaks HTTP with the standard library (``http.client``) and numpy's ``.npy``/``.npz``
formats, and imports nothing else of this package (an import contract in ``pyproject.toml``
checks it), so a pipeline can call a remote service the way it calls the library::

    from kinematics.client import Client, ServiceError

    kin = Client("http://127.0.0.1:8000", api_key=None)
    T = kin.fk("ur5", Q, links=["tool0"])          # (N, 1, 4, 4)
    J = kin.jacobian("ur5", Q, link="tool0")        # (N, 6, 6)
    answer = kin.ik("ur5", T[:, 0], link="tool0")   # {"q", "success", "position_error", ...}
    twists = kin.velocity("ur5", Q, Qd)             # {"world": (N, L, 6), "local": ..., ...}
    model = kin.upload_urdf(open("robot.urdf").read())

Every error answer of the service (a problem-details document, RFC 9457) raises
:class:`ServiceError`, which carries the document (``problem``), its ``status``, ``slug``
(``unknown-model``, ``invalid-joint-values``, ...), ``title`` and ``detail``. The headers of the
last answer (``x-links``, ``x-joint-names``, ``x-out-of-limits``, ...; names in lower case) are
in ``Client.last_headers``. A client is safe to share between threads (one connection per thread).
"""

from __future__ import annotations

import http.client
import io
import json
import os
import threading
import urllib.parse
from typing import Any, Sequence

import numpy as np

NPY = "application/x-npy"
NPZ = "application/x-npz"
#: the problem type prefix of the service's errors
PROBLEM_PREFIX = "urn:kinematics:problem:"


class ServiceError(Exception):
    """An error answer of the service (or no answer): ``status`` (0 when the service could not be
    reached), ``problem`` (the problem-details document), ``slug``, ``title``, ``detail``."""

    def __init__(self, status: int, problem: dict[str, Any]):
        self.status = status
        self.problem = problem
        self.type = problem.get("type", "")
        self.slug = self.type[len(PROBLEM_PREFIX):] if self.type.startswith(PROBLEM_PREFIX) else self.type
        self.title = problem.get("title", "")
        self.detail = problem.get("detail", "")
        super().__init__(f"{status} {self.slug or self.title}: {self.detail or self.title}")


def _npy(arr) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(arr, dtype=np.float64), allow_pickle=False)
    return buf.getvalue()


def _names(values) -> str | None:
    if values is None:
        return None
    if isinstance(values, str):
        return values
    return ",".join(values)


def _split_header(value: str | None) -> list[str] | None:
    if value is None:
        return None
    return [urllib.parse.unquote(v) for v in value.split(",")] if value else []


class Client:
    """The service at ``url`` (``http://host:port``, optionally with a path prefix); ``api_key``
    is sent as ``X-API-Key`` when given; ``timeout`` in seconds."""

    def __init__(self, url: str, api_key: str | None = None, timeout: float = 60.0):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise ValueError(f"url must be http(s)://host[:port][/prefix], got {url!r}")
        self.url = url.rstrip("/")
        self.api_key = api_key
        self.timeout = timeout
        self._scheme, self._host, self._port = parts.scheme, parts.hostname, parts.port
        self._prefix = parts.path.rstrip("/")
        self._local = threading.local()
        self.last_headers: dict[str, str] = {}

    # ------------------------------------------------------------------ transport
    def _connection(self) -> http.client.HTTPConnection:
        conn = getattr(self._local, "conn", None)
        if conn is None:
            cls = http.client.HTTPSConnection if self._scheme == "https" else http.client.HTTPConnection
            conn = self._local.conn = cls(self._host, self._port, timeout=self.timeout)
        return conn

    def close(self) -> None:
        """Close this thread's connection (a later call opens a new one)."""
        conn = getattr(self._local, "conn", None)
        if conn is not None:
            conn.close()
            self._local.conn = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def request(self, method: str, path: str, *, query: dict[str, Any] | None = None, body: bytes | None = None,
                content_type: str | None = None, accept: str = "application/json") -> tuple[int, dict[str, str], bytes]:
        """One HTTP exchange: ``(status, headers, body)`` of a 2xx answer; :class:`ServiceError` otherwise."""
        q = {k: ("true" if v is True else "false" if v is False else v) for k, v in (query or {}).items() if v is not None}
        target = self._prefix + path + ("?" + urllib.parse.urlencode(q, doseq=True) if q else "")
        headers = {"Accept": accept}
        if content_type:
            headers["Content-Type"] = content_type
        if self.api_key is not None:
            headers["X-API-Key"] = self.api_key
        for attempt in (0, 1):  # a kept-alive connection the server has closed: reconnect once
            conn = self._connection()
            try:
                conn.request(method, target, body=body, headers=headers)
                resp = conn.getresponse()
                data = resp.read()
                break
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError) as exc:
                self.close()
                if attempt:
                    raise ServiceError(0, {"title": "no answer", "detail": str(exc)}) from None
            except OSError as exc:
                self.close()
                raise ServiceError(0, {"title": "cannot reach the service", "detail": f"{self.url}: {exc}"}) from None
        self.last_headers = {k.lower(): v for k, v in resp.getheaders()}
        if resp.status >= 400:
            try:
                problem = json.loads(data)
                if not isinstance(problem, dict):
                    raise ValueError
            except ValueError:
                problem = {"title": resp.reason, "detail": data[:500].decode("utf-8", "replace")}
            raise ServiceError(resp.status, problem)
        return resp.status, self.last_headers, data

    def _json(self, method: str, path: str, payload: Any = None, **kw) -> Any:
        body = None if payload is None else json.dumps(payload).encode()
        _, _, data = self.request(method, path, body=body, content_type="application/json" if body else None, **kw)
        return json.loads(data) if data else None

    def _array(self, path: str, arr, query: dict[str, Any]) -> np.ndarray:
        _, _, data = self.request("POST", path, query=query, body=_npy(arr), content_type=NPY, accept=NPY)
        return np.load(io.BytesIO(data), allow_pickle=False)

    @staticmethod
    def _id(model_id: str) -> str:
        return urllib.parse.quote(str(model_id), safe="")

    # ------------------------------------------------------------------ models
    def health(self) -> dict[str, Any]:
        return self._json("GET", "/health")

    def models(self) -> list[dict[str, Any]]:
        """``[{id, name, source, dof, error}]`` of every model the service has."""
        return self._json("GET", "/models")

    def model(self, model_id: str) -> dict[str, Any]:
        """The model's description (joint names, links, joints, limits, ...)."""
        return self._json("GET", f"/models/{self._id(model_id)}")

    def upload_urdf(self, urdf: str | bytes | os.PathLike, name: str | None = None) -> dict[str, Any]:
        """Register a URDF (its text, bytes, or a path to the file); the model's description with its ``id``."""
        if isinstance(urdf, os.PathLike):
            with open(urdf, "rb") as fh:
                urdf = fh.read()
        body = urdf.encode() if isinstance(urdf, str) else bytes(urdf)
        _, _, data = self.request("POST", "/models", query={"name": name}, body=body, content_type="application/xml")
        return json.loads(data)

    def upload_dh(self, table: dict[str, Any]) -> dict[str, Any]:
        """Register a DH table (``name``, ``convention``, ``angles``, ``joints``, ``base``, ``tool``)."""
        return self._json("POST", "/models/dh", table)

    def delete_model(self, model_id: str) -> None:
        self.request("DELETE", f"/models/{self._id(model_id)}")

    # ------------------------------------------------------------------ kinematics
    def fk(self, model_id: str, q, links: Sequence[str] | str | None = None, *, verify: bool = False,
           limits: str = "report", point: Sequence[float] | None = None, floating_base: bool = False,
           normalize: bool = False) -> np.ndarray:
        """Poses ``T_world_link`` (N, L, 4, 4) of ``links`` (None: the leaf links; ``"all"``; names) for
        joint values ``q`` (N, nq) or (nq,); the link order is ``links()``. ``floating_base``: the
        model on a free-flyer root joint (q starts with ``x, y, z, qx, qy, qz, qw``); ``normalize``:
        scale quaternions to unit norm instead of refusing them."""
        query = {"links": _names(links), "verify": verify or None, "limits": limits, "point": _point(point),
                 **_layout(floating_base, normalize)}
        return self._array(f"/models/{self._id(model_id)}/fk", q, query)

    def jacobian(self, model_id: str, q, link: str | None = None, reference: str = "world", *, verify: bool = False,
                 limits: str = "report", point: Sequence[float] | None = None, floating_base: bool = False,
                 normalize: bool = False) -> np.ndarray:
        """Jacobians (N, 6, nv) of ``link`` (None: the first leaf link), linear rows first, in ``reference``."""
        query = {"link": link, "reference": reference, "verify": verify or None, "limits": limits,
                 "point": _point(point), **_layout(floating_base, normalize)}
        return self._array(f"/models/{self._id(model_id)}/jacobian", q, query)

    def analytic_jacobian(self, model_id: str, q, representation: str = "rpy", link: str | None = None, *,
                          components: Sequence[str] | None = None, limits: str = "report",
                          point: Sequence[float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(J_r, r)``: the analytic Jacobian (N, m, dof) of the task vector ``r = (p, phi)`` (N, m)
        of ``link``, orientation as ``representation`` (``rpy``, ``zyx``, ``zyz``, ``quaternion``,
        ``rotvec``, or the subsets ``position``, ``scara``, ``planar``), rows named by ``components()``."""
        query = {"link": link, "representation": representation, "limits": limits, "point": _point(point),
                 "components": None if components is None else ",".join(components)}
        A = self._array(f"/models/{self._id(model_id)}/jacobian", q, query)
        return np.ascontiguousarray(A[:, :, :-1]), np.ascontiguousarray(A[:, :, -1])

    def components(self) -> list[str] | None:
        """The task-vector components of the last analytic Jacobian (``X-Components``)."""
        return _split_header(self.last_headers.get("x-components"))

    def velocity(self, model_id: str, q, qdot, links: Sequence[str] | str | None = None, *,
                 verify: bool = False, limits: str = "report", floating_base: bool = False,
                 normalize: bool = False) -> dict[str, np.ndarray]:
        """Twists of ``links`` for joint values (N, nq) and velocities (N, nv): ``{reference: (N, L, 6)}``,
        linear part first (``local_world_aligned``: the link origin's velocity and the angular
        velocity, world axes)."""
        Q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        Qd = np.atleast_2d(np.asarray(qdot, dtype=np.float64))
        if Q.shape[0] != Qd.shape[0]:
            raise ValueError(f"q and qdot must have as many rows, got {Q.shape} and {Qd.shape}")
        V = self._array(f"/models/{self._id(model_id)}/velocity", np.hstack([Q, Qd]),
                        {"links": _names(links), "verify": verify or None, "limits": limits,
                         **_layout(floating_base, normalize)})
        refs = _split_header(self.last_headers.get("x-twist-references"))
        return {r: np.ascontiguousarray(V[:, :, k]) for k, r in enumerate(refs or [])}

    def ik(self, model_id: str, target, link: str | None = None, *, mode: str = "pose",
           position_tolerance: float | None = None, rotation_tolerance: float | None = None,
           max_iterations: int | None = None, restarts: int | None = None, random_seed: int | None = None,
           verify: bool = False, floating_base: bool = False,
           avoid_collisions: bool = False) -> dict[str, np.ndarray]:
        """Joint values putting ``link`` at ``target`` ((N, 4, 4) or (4, 4) poses ``T_world_link``):
        ``{"q" (N, nq), "success", "position_error", "rotation_error", "iterations"}`` (N,) each;
        ``avoid_collisions``: answers free of self-collision only (``success`` only for a free one),
        and ``"collision_free"`` (N,)."""
        query = {"link": link, "mode": mode, "position_tolerance": position_tolerance,
                 "rotation_tolerance": rotation_tolerance, "max_iterations": max_iterations, "restarts": restarts,
                 "random_seed": random_seed, "verify": verify or None, **_layout(floating_base, False),
                 "avoid_collisions": "true" if avoid_collisions else None}
        return self._npz("POST", f"/models/{self._id(model_id)}/ik", query, _npy(target), NPY)

    def ik_all(self, model_id: str, target, link: str | None = None, *, locked: dict[str, float] | None = None,
               limits: str = "respect", method: str = "auto", verify: bool = False,
               avoid_collisions: bool = False) -> dict[str, np.ndarray]:
        """Every IK solution of ``link`` at ``target`` ((N, 4, 4) or (4, 4)), as ``POST .../ik`` with
        ``solutions: "all"``: ``{"q" (N, K, dof) padded with NaN, "count" (N,), "within_limits",
        "singular", "position_error", "rotation_error" (N, K)}`` (+ ``"colliding"`` (N,) with
        ``avoid_collisions``); ``locked`` holds joints at values (a 7-joint arm to a 6-joint family);
        the family and method are in ``last_headers["x-family"]``, ``["x-method"]``."""
        query = {"link": link, "solutions": "all", "limits": limits, "method": method, "verify": verify or None,
                 "locked": _locked(locked), "avoid_collisions": "true" if avoid_collisions else None}
        return self._npz("POST", f"/models/{self._id(model_id)}/ik", query, _npy(target), NPY)

    def ik_family(self, model_id: str, link: str | None = None, *,
                  locked: dict[str, float] | None = None) -> dict[str, Any]:
        """The structure of the chain to ``link`` (``GET .../ik/family``): ``family``, ``closed_form``,
        ``max_solutions``, which axes meet or are parallel."""
        return self._json("GET", f"/models/{self._id(model_id)}/ik/family",
                          query={"link": link, "locked": _locked(locked)})

    def ik_path(self, model_id: str, waypoints, link: str | None = None, **options: Any) -> dict[str, Any]:
        """A Cartesian path through ``waypoints`` ((M, 4, 4) poses) solved by continuation
        (``POST .../ik/path``); ``options`` as the service's fields (``seed``, ``step``,
        ``max_joint_step``, ``tolerance``, ``locked``, ``avoid_collisions``). The answer's ``q``
        (K, dof), ``targets`` (K, 4, 4), ``position_error``, ``rotation_error`` (K,) are arrays."""
        answer = self._json("POST", f"/models/{self._id(model_id)}/ik/path",
                            _body({"waypoints": waypoints, "link": link, **options}))
        return _arrays(answer, ("q", "targets", "position_error", "rotation_error"))

    # ------------------------------------------------------------------ calibration
    def calibrate(self, model_id: str, measurements=None, link: str | None = None, *, csv: str | bytes | None = None,
                  **options: Any) -> dict[str, Any]:
        """Calibrate the chain to ``link`` from measurements (``POST .../calibrate``): a list of
        ``{"q", "position"}`` / ``{"q", "pose"}`` records, or ``csv`` text (a header naming every
        joint, then ``x,y,z[,qw,qx,qy,qz]``); ``options`` as the service's fields (``point``,
        ``parameters``, ``base``, ``tool``, ``loss``, ``holdout``, ``random_seed``, ``name``, ...).
        The calibrated model is registered: the answer's ``model`` is its id; ``residuals`` are arrays."""
        path = f"/models/{self._id(model_id)}/calibrate"
        if csv is not None:
            query = {"link": link, **{k: _point(v) if k == "point" else v for k, v in options.items()}}
            _, _, data = self.request("POST", path, query=query, content_type="text/csv",
                                      body=csv.encode() if isinstance(csv, str) else bytes(csv))
            answer = json.loads(data)
        else:
            answer = self._json("POST", path, _body({"measurements": measurements, "link": link, **options}))
        answer["residuals"] = _arrays(answer.get("residuals") or {}, ("before", "after"))
        return answer

    def calibration_poses(self, model_id: str, n: int, link: str | None = None, **options: Any) -> dict[str, Any]:
        """``n`` configurations where measuring determines the calibration best
        (``POST .../calibration/poses``): ``q`` (n, dof) an array, ``measure`` the figures."""
        answer = self._json("POST", f"/models/{self._id(model_id)}/calibration/poses",
                            _body({"n": n, "link": link, **options}))
        return _arrays(answer, ("q",))

    # ------------------------------------------------------------------ collision
    def collision(self, model_id: str, q, *, distance: bool = False, margin: float = 0.0,
                  floating_base: bool = False, normalize: bool = False) -> dict[str, Any]:
        """Self-collision of configurations ``q`` ((N, nq) or (nq,), ``POST .../collision``): ``colliding``
        (N,) (a bool for one), ``pairs`` per configuration, ``checked_pairs``, ``links``, ``warnings``;
        with ``distance``: ``min_distance`` (N,) (``inf`` where no pair is checked) and ``closest``."""
        answer = self._json("POST", f"/models/{self._id(model_id)}/collision",
                            _body({"q": q, "distance": distance, "margin": margin, "floating_base": floating_base,
                                   "normalize": normalize}))
        if "min_distance" in answer:  # null (no pair checked) is an infinite distance
            d = np.array(answer["min_distance"], dtype=np.float64)
            d[np.isnan(d)] = np.inf
            answer["min_distance"] = d
        return _arrays(answer, ("colliding",), dtype=bool)

    def collision_matrix(self, model_id: str, format: str = "json") -> dict[str, Any] | str:
        """The allowed-collision matrix (``GET .../collision/matrix``): ``{links, disabled, samples}``,
        or with ``format="srdf"`` the SRDF text (MoveIt's ``disable_collisions``)."""
        path = f"/models/{self._id(model_id)}/collision/matrix"
        if format == "srdf":
            _, _, data = self.request("GET", path, query={"format": "srdf"}, accept="application/xml")
            return data.decode("utf-8")
        return self._json("GET", path)

    # ------------------------------------------------------------------ workspace
    def workspace(self, model_id: str, *, cloud: bool = False, **options: Any) -> dict[str, Any]:
        """The sampled reachable set of a link (``POST .../workspace``; ``options`` as the service's
        fields: ``link``, ``point``, ``samples``, ``voxel``, ``random_seed``, ``measure``,
        ``collision_free``): the summary (``volume``, ``reach``, ``converged``, ...), or with
        ``cloud`` the ``.npz`` arrays (``points`` (N, 3), ``manipulability`` (N,), the dexterity map)."""
        path = f"/models/{self._id(model_id)}/workspace"
        if cloud:
            return self._npz("POST", path, None, json.dumps(_body(options)).encode(), "application/json")
        return self._json("POST", path, _body(options))

    # ------------------------------------------------------------------ closed forms, task vectors
    def symbolic(self, model_id: str, tip: str | None = None, **options: Any) -> dict[str, Any]:
        """Closed forms of the chain to ``tip`` (``POST .../symbolic``; ``options``: ``what``,
        ``format``, ``simplify``, ``representation``, ``components``, ``variables``, ``prefix``, ``timeout``)."""
        return self._json("POST", f"/models/{self._id(model_id)}/symbolic", _body({"tip": tip, **options}))

    def symbolic_dh(self, table: dict[str, Any], **options: Any) -> dict[str, Any]:
        """Closed forms of a DH table whose entries may be symbols (``POST /symbolic/dh``); nothing is registered."""
        return self._json("POST", "/symbolic/dh", _body({"table": table, **options}))

    def task(self, model_id: str, q, link: str | None = None, representation: str = "rpy", *,
             components: Sequence[str] | None = None, limits: str = "report") -> dict[str, Any]:
        """Task vectors ``r`` ((N, m), or (m,) for one configuration) and analytic Jacobians ``J_r``
        ((N, m, dof) or (m, dof)) of ``link`` (``POST .../task``), with ``components`` and ``joint_names``."""
        answer = self._json("POST", f"/models/{self._id(model_id)}/task",
                            _body({"q": q, "link": link, "representation": representation,
                                   "components": None if components is None else list(components),
                                   "limits": limits}))
        return _arrays(answer, ("r", "J_r"))

    # ------------------------------------------------------------------ trajectories
    def trajectory(self, model_id: str, waypoints, *, limits: dict[str, Any], npz: bool = False,
                   **options: Any) -> dict[str, Any]:
        """A timed trajectory through joint ``waypoints`` ((M, dof), e.g. the ``q`` of :meth:`ik_path`;
        ``POST .../trajectory``) under ``limits`` (``{"acceleration": ..., "velocity": ..., "jerk": ...,
        "tool_speed": {"link", "max"}}``, each one number or one per joint); ``options`` as the
        service's fields (``interpolation``, ``blend``, ``rate``). The answer's ``t`` (K,), ``q``,
        ``qd``, ``qdd`` (K, dof) are arrays; with ``npz`` only those and ``duration`` (a float),
        over the binary transport (``method`` and ``joint_names()`` from the headers)."""
        path = f"/models/{self._id(model_id)}/trajectory"
        body = _body({"waypoints": waypoints, "limits": limits, **options})
        if npz:
            answer: dict[str, Any] = self._npz("POST", path, None, json.dumps(body).encode(), "application/json")
            answer["duration"] = float(answer["duration"])
            answer["method"] = self.last_headers.get("x-method")
            return answer
        answer = _arrays(self._json("POST", path, body), ("t", "q", "qd", "qdd"))
        answer["limits"] = _arrays(answer["limits"], ("velocity", "acceleration", "jerk"))
        return answer

    # A new operation follows the pattern above: one method named as the service's path, keyword
    # options as the service's fields (``_body`` drops the unset ones and turns arrays into lists),
    # ``_arrays`` for the array fields of a JSON answer, ``_npz`` where the service answers ``.npz``.

    def _npz(self, method: str, path: str, query: dict[str, Any] | None, body: bytes,
             content_type: str) -> dict[str, np.ndarray]:
        _, _, data = self.request(method, path, query=query, body=body, content_type=content_type, accept=NPZ)
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}

    def joint_names(self) -> list[str] | None:
        """The joint order of the last answer (``X-Joint-Names``), when the service sent it."""
        return _split_header(self.last_headers.get("x-joint-names"))

    def links(self) -> list[str] | None:
        """The link order of the last FK or velocity answer (``X-Links``)."""
        return _split_header(self.last_headers.get("x-links"))


def _point(point: Sequence[float] | None) -> str | None:
    return None if point is None else ",".join(map(repr, map(float, point)))


def _layout(floating_base: bool, normalize: bool) -> dict[str, Any]:
    """Query flags sent only when set (an older service need not know them)."""
    return {"floating_base": "true" if floating_base else None, "normalize": "true" if normalize else None}


def _locked(locked: dict[str, float] | None) -> list[str] | None:
    """``locked`` as the repeated ``joint:value`` query parameters of the service."""
    return None if not locked else [f"{name}:{float(value)!r}" for name, value in locked.items()]


def _plain(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as lists and numbers (what JSON takes)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _body(fields: dict[str, Any]) -> dict[str, Any]:
    """A JSON request body: the fields that are set, arrays as lists."""
    return {k: _plain(v) for k, v in fields.items() if v is not None}


def _arrays(answer: dict[str, Any], keys: Sequence[str], dtype=np.float64) -> dict[str, Any]:
    """``answer`` with its ``keys`` (where present and not null) as numpy arrays."""
    for key in keys:
        if answer.get(key) is not None:
            answer[key] = np.asarray(answer[key], dtype=dtype)
    return answer
