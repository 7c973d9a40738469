"""Catalogue: the format families, and the staged real datasets as locations of those families.

:data:`FORMATS` maps a family name to its reader (``"module:function"``, imported on first use) and the
fields the family fixes (``carmen-corrected`` is the CARMEN reader with ``corrected=True``). Every reader
is called as ``reader(files, name, params=…)`` with ``files`` role → path, and declares its parameters as
a :class:`~slamarena.datasets.source.SourceParams` model: location fields (``path`` and, for MRCLAM,
``robot``), whose :meth:`~slamarena.datasets.source.SourceParams.layout` names the files, and options.

:data:`CATALOGUE` maps a registry name to a :class:`CatalogueEntry`: its family and ``arguments`` — the
location, relative to a data root, and preset options — and what it is (kind, ground truth, citation).
An entry may require a role its family's layout leaves optional (``need``: Dataset 6's Vicon files) and
add optional files (``extra``: a CARMEN log's staged relations, read when present); a camera sequence (a folder of
images) is staged only (``fetchable=False``: no pinned download covers its images). The files of an entry
are all read from one data root (:func:`slamarena.datasets.dataroot.one_root`);
:func:`slamarena.datasets.registry.resolve` turns a name (catalogued, or ``<family>:<path>``) into them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from slamarena.params import params_model
from slamarena.targets import import_target

from .source import Layout, SourceParams

__all__ = ["Format", "FORMATS", "CatalogueEntry", "CATALOGUE"]


@dataclass(frozen=True)
class Format:
    """A format family: its reader, the fields it fixes, and a name that reads a recording at a path (for messages)."""

    reader: str
    example: str
    fixed: dict = field(default_factory=dict)

    def model(self) -> type[SourceParams]:
        return params_model(import_target(self.reader))

    def params(self, arguments: dict) -> SourceParams:
        """The reader's validated parameters: ``arguments`` with the family's fixed fields."""
        return self.model().of(arguments, self.fixed)


#: family → reader; ``<family>:<path>`` (or ``<family>`` with ``params.path``) reads the files at a path
FORMATS: dict[str, Format] = {
    "utias": Format("slamarena.datasets.formats.mrclam:read", "utias:/data/MRCLAM_Dataset7/robot1"),
    "victoria_park": Format("slamarena.datasets.formats.victoria_park:load", "victoria_park:/data/victoria_park.txt"),
    "plaza": Format(
        "slamarena.datasets.formats.plaza:read", "plaza:/data/Plaza3 (for Plaza3_DR.txt, Plaza3_TD.txt, Plaza3_.mat)"
    ),
    "g2o": Format("slamarena.datasets.formats.g2o:load", "g2o:/data/graph.g2o"),
    "toro": Format("slamarena.datasets.formats.toro:load", "toro:/data/graph.graph"),
    "isam": Format("slamarena.datasets.formats.isam:load", "isam:/data/graph.txt"),
    "carmen": Format("slamarena.datasets.formats.carmen:load", "carmen:/data/log.clf"),
    "kitti": Format("slamarena.datasets.formats.kitti_odometry:read", "kitti:/data/kitti/sequences/05"),
    "vamr": Format("slamarena.datasets.formats.vamr:read", "vamr:/data/vamr/ex01"),
    "carmen-corrected": Format(
        "slamarena.datasets.formats.carmen:load", "carmen-corrected:/data/log-corrected.log", {"corrected": True}
    ),
    "bag": Format("slamarena.datasets.formats.bag:load", "bag:/data/run.bag (or a ROS 2 bag folder, or run.mcap)"),
    "carpark": Format(
        "slamarena.datasets.formats.carpark:read", "carpark:/data/acfr_carpark (for data_set.mat, beac_juan3.mat)"
    ),
}


@dataclass(frozen=True)
class CatalogueEntry:
    name: str
    family: str
    kind: str
    ground_truth: str
    arguments: dict
    citation: str = ""
    need: dict[str, bool] = field(default_factory=dict)
    extra: dict[str, str] = field(default_factory=dict)
    #: False: staged only — a folder of images that no pinned download covers (``slamarena data fetch`` refuses)
    fetchable: bool = True

    @property
    def reader(self) -> str:
        return FORMATS[self.family].reader

    def layout(self) -> Layout:
        """The entry's files: its family's layout at its location, ``need`` applied, ``extra`` added as optional roles."""
        base = FORMATS[self.family].params(self.arguments).layout()
        return Layout(
            {**base.files, **{role: (rel,) for role, rel in self.extra.items()}}, base.optional | frozenset(self.extra)
        ).needing(self.need)

    @property
    def files(self) -> tuple[str, ...]:
        """Every candidate path of every role, relative to a data root."""
        return tuple(c for candidates in self.layout().files.values() for c in candidates)


# ---------------------------------------------------------------------------- citations
_MRCLAM = (
    'K.Y.K. Leung, Y. Halpern, T.D. Barfoot, H.H.T. Liu, "The UTIAS Multi-Robot Cooperative Localization '
    'and Mapping Dataset", IJRR 30(8):969-974, 2011'
)
_VICTORIA = (
    'J. Guivant, E. Nebot, "Optimization of the simultaneous localization and map-building algorithm for '
    'real-time implementation", IEEE T-RA 17(3), 2001; pre-processing: M. Kaess, A. Ranganathan, F. Dellaert, '
    '"iSAM: Incremental Smoothing and Mapping", IEEE TRO 24(6), 2008'
)
_ISAM = 'M. Kaess, A. Ranganathan, F. Dellaert, "iSAM: Incremental Smoothing and Mapping", IEEE TRO 24(6), 2008'
_OLSON = (
    'E. Olson, J. Leonard, S. Teller, "Fast iterative alignment of pose graphs with poor initial estimates", ICRA 2006'
)
_SESYNC = (
    'D.M. Rosen, L. Carlone, A.S. Bandeira, J.J. Leonard, "SE-Sync: a certifiably correct algorithm for '
    'synchronization over the special Euclidean group", IJRR 38(2-3), 2019'
)
_CARLONE2D = 'L. Carlone, A. Censi, "From angular manifolds to the integer lattice", IEEE TRO 30(2), 2014'
_CARLONE3D = 'L. Carlone, R. Tron, K. Daniilidis, F. Dellaert, "Initialization techniques for 3D SLAM", ICRA 2015'
_GTSAM = "F. Dellaert and contributors, GTSAM (Georgia Tech), examples/Data"
_LAGO = 'L. Carlone et al., "A fast and accurate approximation for planar pose graph optimization", IJRR 2014'
_RADISH = 'A. Howard, N. Roy, "The Robotics Data Set Repository (Radish)", 2003'
_PLAZA = (
    'J. Djugash, S. Singh, G. Kantor, W. Zhang, "Range-only SLAM for robots operating cooperatively with sensor '
    'networks", ICRA 2006; GTSAM copies: B. Boots, G. Gordon, "A spectral learning approach to range-only SLAM", ICML 2013'
)
_CARPARK = (
    'J. Guivant, E. Nebot, "Optimization of the simultaneous localization and map-building algorithm for '
    'real-time implementation", IEEE T-RA 17(3), 2001; ACFR (University of Sydney) Car Park dataset'
)
_KUEMMERLE = (
    'R. Kuemmerle et al., "On measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4):387-407, 2009'
)


def _mrclam() -> dict[str, CatalogueEntry]:
    out = {}
    for dataset in (1, 6):
        for robot in range(1, 6):
            name = f"utias:{dataset}/robot{robot}"
            out[name] = CatalogueEntry(
                name,
                "utias",
                "landmarks (range-bearing, velocity odometry, real indoor)",
                "Vicon poses + surveyed landmarks" if dataset == 6 else "surveyed landmarks only",
                {"path": f"utias_mrclam/MRCLAM_Dataset{dataset}", "robot": robot},
                _MRCLAM,
                need={"groundtruth": True} if dataset == 6 else {},
            )
    return out


def _plaza() -> dict[str, CatalogueEntry]:
    return {
        f"plaza:{run}": CatalogueEntry(
            f"plaza:{run}",
            "plaza",
            "range-only (beacon ranges + odometry increments, real outdoor)",
            "GPS-based poses + surveyed beacons",
            {"path": f"plaza_range_only/{run}"},
            _PLAZA,
            need={"truth": True},
        )
        for run in ("Plaza1", "Plaza2")
    }


_G2O = {
    # name: (file, kind, ground truth, ground-truth file, citation)
    "intel": ("sesync_g2o/intel.g2o", "pose graph 2D, real (Intel lab)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "MIT": ("sesync_g2o/MIT.g2o", "pose graph 2D, real (Killian Court)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "CSAIL": (
        "sesync_g2o/CSAIL.g2o",
        "pose graph 2D, real (no initial guess)",
        "none",
        None,
        f"{_SESYNC}; {_CARLONE2D}",
    ),
    "ais2klinik": (
        "sesync_g2o/ais2klinik.g2o.gz",
        "pose graph 2D, real (Freiburg)",
        "none",
        None,
        f"{_SESYNC}; {_CARLONE2D}",
    ),
    "manhattan": (
        "sesync_g2o/manhattan.g2o",
        "pose graph 2D, simulated (M3500, no initial guess)",
        "true poses (iSAM noise-free file)",
        "isam_data/groundtruth/manhattanOlson3500_groundtruth.txt",
        f"{_OLSON}; {_SESYNC}",
    ),
    "city10000": (
        "sesync_g2o/city10000.g2o.gz",
        "pose graph 2D, simulated",
        "true poses (iSAM noise-free file)",
        "isam_data/groundtruth/city10000_groundtruth.txt",
        f"{_ISAM}; {_SESYNC}",
    ),
    "parking-garage": (
        "sesync_g2o/parking-garage.g2o.gz",
        "pose graph 3D, real",
        "none",
        None,
        f"{_SESYNC}; {_CARLONE3D}",
    ),
    "sphere2500": (
        "sesync_g2o/sphere2500.g2o.gz",
        "pose graph 3D, simulated",
        "none",
        None,
        f"{_SESYNC}; {_CARLONE3D}",
    ),
    "smallGrid3D": ("sesync_g2o/smallGrid3D.g2o", "pose graph 3D, simulated", "none", None, _SESYNC),
    "tinyGrid3D": ("sesync_g2o/tinyGrid3D.g2o", "pose graph 3D, simulated", "none", None, _SESYNC),
    "noisyToyGraph": (
        "gtsam_examples_data/noisyToyGraph.txt",
        "pose graph 2D, toy",
        "reference answer (GTSAM's, within 1e-2 of the optimum): g2o:optimizedNoisyToyGraph",
        None,
        f"{_GTSAM}; {_LAGO}",
    ),
    "optimizedNoisyToyGraph": (
        "gtsam_examples_data/optimizedNoisyToyGraph.txt",
        "pose graph 2D, toy (GTSAM's reference answer)",
        "is GTSAM's reference answer (LAGO-based, 2.4e-3 from the optimum)",
        None,
        f"{_GTSAM}; {_LAGO}",
    ),
    "orientationsNoisyToyGraph": (
        "gtsam_examples_data/orientationsNoisyToyGraph.txt",
        "pose graph 2D, toy (LAGO)",
        "is the expected LAGO answer",
        None,
        f"{_GTSAM}; {_LAGO}",
    ),
    "pose2example": ("gtsam_examples_data/pose2example.txt", "pose graph 2D, toy", "none", None, _GTSAM),
    "toyExample": ("gtsam_examples_data/toyExample.g2o", "pose graph 3D, toy", "none", None, _GTSAM),
    "Klaus3": ("gtsam_examples_data/Klaus3.g2o", "pose graph 3D, toy", "none", None, _GTSAM),
    "pose3example": ("gtsam_examples_data/pose3example.txt", "pose graph 3D, toy", "none", None, _GTSAM),
    "pose3example-grid": ("gtsam_examples_data/pose3example-grid.txt", "pose graph 3D, toy", "none", None, _GTSAM),
    "simpleGraph10gradIter": (
        "gtsam_examples_data/simpleGraph10gradIter.txt",
        "pose graph 3D, toy",
        "none",
        None,
        _GTSAM,
    ),
}
_TORO = {
    "w100": ("gtsam_examples_data/w100.graph", "pose graph 2D (TORO), simulated Manhattan world", "none"),
    "example": ("gtsam_examples_data/example.graph", "pose graph 2D (TORO) + bearing-range landmarks", "none"),
}
_ISAM_FILES = {
    "manhattanOlson3500": (
        "isam_data/manhattanOlson3500.txt",
        "isam_data/groundtruth/manhattanOlson3500_groundtruth.txt",
        "pose graph 2D, simulated (M3500)",
        f"{_OLSON}; {_ISAM}",
    ),
    "city10000": (
        "isam_data/city10000.txt.gz",
        "isam_data/groundtruth/city10000_groundtruth.txt",
        "pose graph 2D, simulated",
        _ISAM,
    ),
    "cityTrees10000": (
        "isam_data/cityTrees10000.txt",
        "isam_data/groundtruth/cityTrees10000_groundtruth.txt",
        "pose + landmark graph 2D, simulated (100 trees)",
        _ISAM,
    ),
    "w20000": ("gtsam_examples_data/w20000.txt.gz", None, "pose graph 2D, simulated Manhattan world", _GTSAM),
}
#: CARMEN logs: name → (file, no-return threshold max_range [m], note). 80 m: the SICK LMS codes 81.8-81.91 m
#: (no real return above 62 m in any log); 50 m: logs whose readings pile up at 50-51.3 m; 32.767 m: int16 mm code.
_CARMEN_RAW = {
    "intel": ("radish_laser_logs/intel.clf.bz2", 80.0, "Intel Research Lab Seattle (D. Haehnel)"),
    "fr079": ("radish_laser_logs/fr079.clf.bz2", 80.0, "Freiburg building 079 (C. Stachniss)"),
    "aces": ("radish_laser_logs/aces.clf.bz2", 50.0, "ACES building, UT Austin (P. Beeson)"),
    "mit-csail": ("radish_laser_logs/mit-csail.clf.bz2", 80.0, "MIT CSAIL building (C. Stachniss)"),
    "fr-clinic": ("radish_laser_logs/fr-clinic_robotlaser.clf.bz2", 80.0, "Freiburg University Hospital (AIS)"),
}
#: the Kümmerle et al. relations files staged beside the raw logs (radish_laser_logs/relations/SOURCE.md)
_CARMEN_RELATIONS = {
    name: f"radish_laser_logs/relations/{name}.relations" for name in ("intel", "fr079", "mit-csail", "fr-clinic")
}
_CARMEN_CORRECTED = {
    "acapulco": 50.0,
    "aces": 50.0,
    "belgioioso": 80.0,
    "csail": 80.0,
    "edmonton": 50.0,
    "fhw": 50.0,
    "freiburg-079": 80.0,
    "freiburg-101": 80.0,
    "freiburg-campus": 80.0,
    "infinite-corridor": 50.0,
    "intel": 80.0,
    "orebro": 32.767,
    "seattle": 80.0,
}


def _graphs() -> dict[str, CatalogueEntry]:
    out = {}
    for name, (rel, kind, truth, gt, cite) in _G2O.items():
        out[f"g2o:{name}"] = CatalogueEntry(f"g2o:{name}", "g2o", kind, truth, {"path": rel, "ground_truth": gt}, cite)
    for name, (rel, kind, truth) in _TORO.items():
        out[f"g2o:{name}"] = CatalogueEntry(f"g2o:{name}", "toro", kind, truth, {"path": rel}, _GTSAM)
    for name, (rel, gt, kind, cite) in _ISAM_FILES.items():
        truth = "true poses" + (" and landmarks" if "Trees" in name else "") + " (noise-free file)" if gt else "none"
        out[f"isam:{name}"] = CatalogueEntry(
            f"isam:{name}", "isam", kind, truth, {"path": rel, "ground_truth": gt}, cite
        )
    return out


def _carmen() -> dict[str, CatalogueEntry]:
    out = {}
    for name, (rel, max_range, owner) in _CARMEN_RAW.items():
        relations = _CARMEN_RELATIONS.get(name)
        out[f"carmen:{name}"] = CatalogueEntry(
            f"carmen:{name}",
            "carmen",
            "laser log 2D (scans + odometry), real",
            "relations (Kümmerle et al. 2009), where staged" if relations else "none",
            {"path": rel, "max_range": max_range},
            f"{owner}; {_RADISH}; {_KUEMMERLE}",
            extra={"relations": relations} if relations else {},
        )
    for name, max_range in _CARMEN_CORRECTED.items():
        out[f"carmen-corrected:{name}"] = CatalogueEntry(
            f"carmen-corrected:{name}",
            "carmen-corrected",
            "laser log 2D with SLAM-corrected poses",
            "SLAM reference poses (not independent)",
            {"path": f"carmen_corrected_logs/{name}-corrected.log.gz", "max_range": max_range},
            f"{_RADISH}; data owners per log (via acschaefer/ple)",
        )
    return out


_VICTORIA_KIND = "landmarks (odometry increments + tree observations, real outdoor)"

CATALOGUE: dict[str, CatalogueEntry] = {
    **_mrclam(),
    "victoria_park": CatalogueEntry(
        "victoria_park",
        "victoria_park",
        _VICTORIA_KIND + ", GTSAM's copy (covariance noise columns)",
        "none",
        {"path": "victoria_park/victoria_park_gtsam.txt", "variant": "gtsam"},
        _VICTORIA,
    ),
    "victoria_park:isam": CatalogueEntry(
        "victoria_park:isam",
        "victoria_park",
        _VICTORIA_KIND + ", iSAM's copy (square-root information noise columns)",
        "none",
        {"path": "victoria_park/victoriaPark_isam.txt", "variant": "isam"},
        _VICTORIA,
    ),
    **_plaza(),
    "carpark": CatalogueEntry(
        "carpark",
        "carpark",
        "raw laser with intensity (retro-reflective beacons) + speed and steering (Ackerman), real outdoor",
        "GPS (5 Hz) + 15 surveyed beacons",
        {"path": "acfr_carpark"},
        _CARPARK,
    ),
    **_graphs(),
    **_carmen(),
    "bag:aces": CatalogueEntry(
        "bag:aces",
        "bag",
        "laser log 2D (scans + odometry), real, as a ROS 1 bag (synthetic stamps: ros_bags/SOURCE.md)",
        "none",
        {"path": "ros_bags/aces.clf2bag.bag"},
        f"P. Beeson (UT Austin); {_RADISH}; bag made by INESCTEC/ricoslam's clf2bag.py",
    ),
    "kitti:00": CatalogueEntry(
        "kitti:00",
        "kitti",
        "camera (rectified stereo, grey), real driving: the first 200 frames of sequence 00 (100 with a right image)",
        "KITTI poses (GPS/INS)",
        {"path": "kitti_odometry/sequences/00"},
        'A. Geiger, P. Lenz, R. Urtasun, "Are we ready for autonomous driving? The KITTI vision benchmark suite", '
        "CVPR 2012 (CC BY-NC-SA 3.0)",
        need={"poses": True},
        fetchable=False,
    ),
    "vamr:checkerboard": CatalogueEntry(
        "vamr:checkerboard",
        "vamr",
        "camera (monocular, radial distortion), real hand-held around a planar checkerboard, 300 frames",
        "poses from the board (the course's calibration)",
        {"path": "vamr_checkerboard"},
        'D. Scaramuzza, "Vision Algorithms for Mobile Robotics", UZH Robotics and Perception Group (exercise data)',
        fetchable=False,
    ),
}
