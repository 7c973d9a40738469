"""``slamarena data fetch NAME``: download a dataset's files with pinned URLs and sha256 (pooch).

Every file is pinned to the exact commit named in its ``SOURCE.md`` (raw.githubusercontent.com)
and checked against the sha256 of the upstream content. Files that the stager gzip-compressed
(``compressed=True`` below) are published uncompressed: the hash is that of the published file,
and after verification the file is gzip-compressed into the cache at the path the catalogue
expects. Downloads go to :func:`slamarena.datasets.dataroot.cache_dir`, which is itself a data root;
as a dataset is read from one root, every file of it goes there unless some place already holds the
dataset (its required files), whatever other roots hold a part of it.

pooch is imported inside :func:`fetch` only (the data layer depends on numpy + stdlib).
"""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

from slamarena.errors import UserError

from .dataroot import cache_dir

__all__ = ["FILES", "fetch", "url_of", "FetchError"]

RAW = "https://raw.githubusercontent.com/"

#: path under the data root → (owner/repo/commit/path upstream, sha256 of the upstream file, stager-compressed)
FILES: dict[str, tuple[str, str, bool]] = {
    "utias_mrclam/MRCLAM_Dataset1/Barcodes.dat": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Barcodes.dat",
        "11049b54d75d8142297fe6473686dc406e0d74312b1dc679c6f3c3d826328a0b",
        False,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Landmark_Groundtruth.dat": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Landmark_Groundtruth.dat",
        "682c416aafb066992e964ef4233ee9054f41f0e18501409bf5efd005fef152d8",
        False,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot1_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot1_Measurement.dat",
        "3257dd730fe65773e0a093c2aa45da998ab8c790f666d0477f6976d03aef1abf",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot1_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot1_Odometry.dat",
        "51a3f6362684a3993c50fcde83fd89eac49f68acd1568cb2f399680b88afab81",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot2_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot2_Measurement.dat",
        "af9746edb6d6023aebb4a09105988db9b530391de2de4f9041ecea30977472e6",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot2_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot2_Odometry.dat",
        "a4c26b277cfdb984f2172560d49dddd4bbddcfedaeaf23daa87928cd8167d1e2",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot3_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot3_Measurement.dat",
        "2ad96e0d6a4fab5ee165ddb946c554ee0d80aeaf4def12621139b48410fb4a84",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot3_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot3_Odometry.dat",
        "787fe8b11d2506d764c16db6265b63ce6cca8301bc257a70f1470b46b00dd26f",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot4_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot4_Measurement.dat",
        "4a8cb16e910b963e3614b12e08ad87a392078df61b5e81dc22074658f5e59568",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot4_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot4_Odometry.dat",
        "74b824e3cf3ac1dc1b9bcd1623174088256810c64f98d1debd8ac2ed721cfb02",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot5_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot5_Measurement.dat",
        "31813e405d86e6a0de5243bea2ce39035f6daef0a54e0fd8949d14333f8a6593",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset1/Robot5_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset1/Robot5_Odometry.dat",
        "689313f51d214ce4d858fbce526b505c08ef5ab850e0758d6163721d0d9064dc",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Barcodes.dat": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Barcodes.dat",
        "3448dfa8fdf7c6e52c4d778c9e3166a704fc1b3f388e5f274532ff1af3b37362",
        False,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Landmark_Groundtruth.dat": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Landmark_Groundtruth.dat",
        "eae8cb0aed1ad57910578ece4288d861940427cef95551fd53ca3997f16ecdb1",
        False,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot1_Groundtruth.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot1_Groundtruth.dat",
        "fee9661b3415b162e948c02cf56d3646ddc751c70f22c8cbd431fcde6d8a7b76",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot1_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot1_Measurement.dat",
        "571ca6c9978df9503062e014b0e46101623523d46a64dfe789e8aa1792b0e2e3",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot1_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot1_Odometry.dat",
        "575febdf8022bd0a0da163e5078bb27413165196afe657974437aad215be5d0b",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot2_Groundtruth.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot2_Groundtruth.dat",
        "793fa0860e95a8b3d8422ae94614541649e895e89d7ab68c2d05e98965d1dc91",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot2_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot2_Measurement.dat",
        "36aaf4bde8f4880096f10324b490c0156e8ca71583375770a6fd0e725237fa04",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot2_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot2_Odometry.dat",
        "dde2e7d70a8ff9355038d38e3e38a06419e060bff96607778506a01d90089701",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot3_Groundtruth.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot3_Groundtruth.dat",
        "1fffc5b2ff732a4bfd617ee35796f67ff6300eafcf3de0d645e3049df035fce8",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot3_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot3_Measurement.dat",
        "1975db530c0dfa3c215333cdc9432428bd6c3cb12348cd4aab12ed8a30f8dc1c",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot3_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot3_Odometry.dat",
        "a4c50b28fd9fe8a4e4830ff53cbb7812a52fe2d88f2258c66e275232fb3c7326",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot4_Groundtruth.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot4_Groundtruth.dat",
        "eaba04bcb96f72f67aeb7e1098a994ac739e699cd03f0cfa21fd083a63a7f3d4",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot4_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot4_Measurement.dat",
        "b0d87a0d8c5bae9f761c42494a0d7f7d1ac48df4922a6af72811e2f2b82a063c",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot4_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot4_Odometry.dat",
        "b5270104419bbb5b1e5ddf8d7bb31b6f4496a55f0d1b643b743af62ad06a31d6",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot5_Groundtruth.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot5_Groundtruth.dat",
        "fd98a23d555782ccad449d3cd4ff61e252891b6968248e68882b8cb6bfd4875c",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot5_Measurement.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot5_Measurement.dat",
        "4f8bf6b4421a97b093503f6526365ae38f5d61361507c8bf1b0ad002a4c2e00e",
        True,
    ),
    "utias_mrclam/MRCLAM_Dataset6/Robot5_Odometry.dat.gz": (
        "curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/MRCLAM_Dataset6/Robot5_Odometry.dat",
        "11297ae2f083f6d394f093b690ff4b467d3e466ab99525b9f02ee0fa4d15d817",
        True,
    ),
    "sesync_g2o/CSAIL.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/CSAIL.g2o",
        "66d99ac857a9849d814d214a9ebd0d4876d5d40f0a37be9330c1ff6e6e9daaa6",
        False,
    ),
    "sesync_g2o/MIT.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/MIT.g2o",
        "e5922be0d0689c7a5bc04c58adf3a8e697e240bdd7691cc4218470eaf92956eb",
        False,
    ),
    "sesync_g2o/ais2klinik.g2o.gz": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/ais2klinik.g2o",
        "e388ebd8523987c1004082d7eaeb5e6fb640b773d05ccebeef1ce1e8df64e1e7",
        True,
    ),
    "sesync_g2o/city10000.g2o.gz": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/city10000.g2o",
        "df5988994339e990be198a36e7f640e31a5a1b26df3ed400363fafc49d5ca630",
        True,
    ),
    "sesync_g2o/intel.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/intel.g2o",
        "3e0724c048e0ba524be9dd268a8b78e19a2497043143584cbb61310638b15c4b",
        False,
    ),
    "sesync_g2o/manhattan.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/manhattan.g2o",
        "6ae8d30971720c1af24a00c4b2dd5c5ddafbbbe488bfc771145c47decbffb248",
        False,
    ),
    "sesync_g2o/parking-garage.g2o.gz": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/parking-garage.g2o",
        "3ac0a31bfb601d7455d451e2546655cb5dececf51a7823f57c8a7e0fe1ca6527",
        True,
    ),
    "sesync_g2o/smallGrid3D.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/smallGrid3D.g2o",
        "9ea56c2ad1ebcc322560eb2f8d83cb3a60f99e2e2acc35e097b1162cdbafd649",
        False,
    ),
    "sesync_g2o/sphere2500.g2o.gz": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/sphere2500.g2o",
        "104ab57593394f24351d9f692f3b923f8b98fff1eb638c64356cf5049e06cf3c",
        True,
    ),
    "sesync_g2o/tinyGrid3D.g2o": (
        "david-m-rosen/SE-Sync/9b631b6b82d8aa7d32ab846412ae1c070412b7b6/data/tinyGrid3D.g2o",
        "c341eb0d09f7556b337be5a62b9354384885333a25fa718fd699fafb19620493",
        False,
    ),
    "isam_data/city10000.txt.gz": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/city10000.txt",
        "7b2885aa3f76e0ce513c1a4ea270557d5c884509064f4e1678adf215a2ec105a",
        True,
    ),
    "isam_data/cityTrees10000.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/cityTrees10000.txt",
        "62760029d3b492f357117a3922b57a68585b137fbcb7a115def597ab7a4f2c24",
        False,
    ),
    "isam_data/groundtruth/city10000_groundtruth.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/groundtruth/city10000_groundtruth.txt",
        "ebdf93eaeb3498dcebc7ba0b88ff6a3dc86d06767b1e42c166d686d7323051ab",
        False,
    ),
    "isam_data/groundtruth/cityTrees10000_groundtruth.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/groundtruth/cityTrees10000_groundtruth.txt",
        "0ff138c64003d0fcf7a8d864a99de4d98d57f7b487096fa81abd7f53a8b63c04",
        False,
    ),
    "isam_data/groundtruth/manhattanOlson3500_groundtruth.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/groundtruth/manhattanOlson3500_groundtruth.txt",
        "058854bc5943514dea9b40559df56bfb82e8d78261eb8227a9a725c4a7d0d533",
        False,
    ),
    "isam_data/manhattanOlson3500.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/manhattanOlson3500.txt",
        "cbca9a57a97e43b8a32e3d76d7c78d285e2719aae08fa005d601feb0573c7bbf",
        False,
    ),
    "plaza_range_only/Plaza1_.mat": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza1_.mat",
        "9ccbfec19942eabecfa3206bff983bf708b98d6c7db462d81c55376f92d75847",
        False,
    ),
    "plaza_range_only/Plaza1_DR.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza1_DR.txt",
        "41233e2e97d482c12a6cd074583c15fb47918d015a3d59e90d8b3b3cfba8b09d",
        False,
    ),
    "plaza_range_only/Plaza1_TD.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza1_TD.txt",
        "56b6cdd86327da38143c0f2b2a3e4337908e1d3447c32b2897005ebbd3326be8",
        False,
    ),
    "plaza_range_only/Plaza2_.mat": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza2_.mat",
        "72f0abe0fea2050eb5ee1cffc8c43823266a35785b7cdecac4ec5eae727561a2",
        False,
    ),
    "plaza_range_only/Plaza2_DR.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza2_DR.txt",
        "afd63364d0650e90ca1a9f13ceb9105104f52ab6768beb1cdf584ab9aada024e",
        False,
    ),
    "plaza_range_only/Plaza2_TD.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Plaza2_TD.txt",
        "05e884e9e131b805db71bacd345b8606e8d53fe21a6b5a3acbbb4f33d0a68cfd",
        False,
    ),
    "gtsam_examples_data/Klaus3.g2o": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/Klaus3.g2o",
        "28a134d684e53ae7d60cebb4c02a75897f01b561d2958dcdd1d2a07741d9be29",
        False,
    ),
    "gtsam_examples_data/example.graph": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/example.graph",
        "388ea4254a2f999d63323051d1e11922dbcfa9c0703d180fa38df39ce3f46247",
        False,
    ),
    "gtsam_examples_data/noisyToyGraph.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/noisyToyGraph.txt",
        "9b2d2930cf50b2b2c756172f50c34503c41644e529727bd7a4960f6e785ff859",
        False,
    ),
    "gtsam_examples_data/optimizedNoisyToyGraph.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/optimizedNoisyToyGraph.txt",
        "08f1962a9aff2971151b31e9535df199d83de065a5f194f794e55451f95e4767",
        False,
    ),
    "gtsam_examples_data/orientationsNoisyToyGraph.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/orientationsNoisyToyGraph.txt",
        "bc2ab0aae5cd3d07d639d1725714475bcae25f42300f1d78952c0f71b1abbe40",
        False,
    ),
    "gtsam_examples_data/pose2example.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/pose2example.txt",
        "578f33a41273d7e7be0bd542e9a6bc8963bbb86c33891f4851d07b633035ec8f",
        False,
    ),
    "gtsam_examples_data/pose3example-grid.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/pose3example-grid.txt",
        "8b4223efe214fcc2cdcd0cfabfcc8b85e957b8afb9119657477ca8ad96b9208c",
        False,
    ),
    "gtsam_examples_data/pose3example.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/pose3example.txt",
        "bd92c6ed222b75769c1301aae1290af66ea6172ac3266b341697980a4976eebb",
        False,
    ),
    "gtsam_examples_data/simpleGraph10gradIter.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/simpleGraph10gradIter.txt",
        "c313fb7b8328eae3f19cbb8c828c35b77df73ac73997d0da1a88c0c448fdf8c7",
        False,
    ),
    "gtsam_examples_data/toyExample.g2o": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/toyExample.g2o",
        "d3f97f27670fd890c6c53a8c58f0a12e53417a4c7198dcf84d425892eba820b9",
        False,
    ),
    "gtsam_examples_data/w100.graph": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/w100.graph",
        "00e68e8ba3985213814862f53a533916a005c2b40d374d840f6d069d91abaa06",
        False,
    ),
    "gtsam_examples_data/w20000.txt.gz": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/w20000.txt",
        "9690b10bc2c7f2cebfb1969dd1643b5813aa3db50b40d98685c36c4eeae69c57",
        True,
    ),
    "radish_laser_logs/relations/intel.relations": (
        "INESCTEC/ricoslam/52bfaa91c8e5e56f119265d409b1692ca29d48d2/inesctec_mrdt_slam_2d_datasets/data/intel.relations",
        "330378f153eeae652d6756c1746f335801f66c3e097d90611548e6c4f593c359",
        False,
    ),
    "radish_laser_logs/relations/fr079.relations": (
        "INESCTEC/ricoslam/52bfaa91c8e5e56f119265d409b1692ca29d48d2/inesctec_mrdt_slam_2d_datasets/data/fr079.relations",
        "7e7f06b4aca455cb68f1f23d04e7c7316c5e17773e872734c860ed7a274cdfc7",
        False,
    ),
    "radish_laser_logs/relations/mit-csail.relations": (
        "INESCTEC/ricoslam/52bfaa91c8e5e56f119265d409b1692ca29d48d2/inesctec_mrdt_slam_2d_datasets/data/mit-csail.relations",
        "ffd7ebe97fa1738913931e39ca643ee0a1b67de80499b0197a3d01abad0f589d",
        False,
    ),
    "radish_laser_logs/relations/fr-clinic.relations": (
        "INESCTEC/ricoslam/52bfaa91c8e5e56f119265d409b1692ca29d48d2/inesctec_mrdt_slam_2d_datasets/data/fr-clinic.relations",
        "583b7bba8c1a3ef1f7ad41221c151534333e71b52f5fc267d5e343c79355300c",
        False,
    ),
    "ros_bags/aces.clf2bag.bag": (
        "INESCTEC/ricoslam/52bfaa91c8e5e56f119265d409b1692ca29d48d2/inesctec_mrdt_slam_2d_datasets/bag/aces.clf2bag.bag",
        "ed6669e3522179079241ba5b29130ad9215b668fc3a40e1fc687ab02cdec29e0",
        False,
    ),
    "radish_laser_logs/aces.clf.bz2": (
        "MOLAorg/mola_test_datasets/13a2ed141116bc654e14ffca1d88fb740b3d1253/datasets/radish/aces.clf.bz2",
        "b663e2976ed0621c2bec0cc20c4e7cc117b88db5bac6f921d3fbaa9685d2232a",
        False,
    ),
    "radish_laser_logs/fr-clinic_robotlaser.clf.bz2": (
        "MOLAorg/mola_test_datasets/13a2ed141116bc654e14ffca1d88fb740b3d1253/datasets/radish/fr-clinic_robotlaser.clf.bz2",
        "f1123753be7308178547d487df96dfc230669a55c21253c3225c7627b124d6d8",
        False,
    ),
    "radish_laser_logs/fr079.clf.bz2": (
        "MOLAorg/mola_test_datasets/13a2ed141116bc654e14ffca1d88fb740b3d1253/datasets/radish/fr079.clf.bz2",
        "9c3930e17957889c24986390dc7fe3eeddd3d7019a8172085dbed8a28a0e6b77",
        False,
    ),
    "radish_laser_logs/intel.clf.bz2": (
        "MOLAorg/mola_test_datasets/13a2ed141116bc654e14ffca1d88fb740b3d1253/datasets/radish/intel.clf.bz2",
        "d9ce4addefc9405d5e78fd883d2214766552537d262009f8e6f0137885f9f72a",
        False,
    ),
    "radish_laser_logs/mit-csail.clf.bz2": (
        "MOLAorg/mola_test_datasets/13a2ed141116bc654e14ffca1d88fb740b3d1253/datasets/radish/mit-csail.clf.bz2",
        "e010703e450a20e71a97b0e8de88d9474040c8106e547ff894d885e67a309b47",
        False,
    ),
    "carmen_corrected_logs/acapulco-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/acapulco-corrected.log.gz",
        "fbd19a018534dee751606a9520fd6be25c86f3d7f1f7d849b1834d047b330116",
        False,
    ),
    "carmen_corrected_logs/aces-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/aces-corrected.log.gz",
        "5434d44384166250608a64d3a8c32de84512f82c46cb60a2657f138592024569",
        False,
    ),
    "carmen_corrected_logs/belgioioso-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/belgioioso-corrected.log.gz",
        "a130e3e6d9e5ec5e6a7f94cbb5cb6bca2df2626c7ed6bebb7b7a282253b10f6e",
        False,
    ),
    "carmen_corrected_logs/csail-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/csail-corrected.log.gz",
        "a98de24fc319651f231f9a8625b78bf1972312b86f7b00d2ddc979c4ac92ae2d",
        False,
    ),
    "carmen_corrected_logs/edmonton-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/edmonton-corrected.log.gz",
        "96599a91e0cc9cb2570dbb92f92bbdf1e3a405b16aa99f6d3ce1a703011befdb",
        False,
    ),
    "carmen_corrected_logs/fhw-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/fhw-corrected.log.gz",
        "4233abbfbc15baaddc730aceb3482dc660b25c9d5757005fff97a3fe083595b8",
        False,
    ),
    "carmen_corrected_logs/freiburg-079-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/freiburg-079-corrected.log.gz",
        "0631d30baf4b9d1d209af47da9096e876e1b4cb3d5a2d68ef9c39c5a2360a466",
        False,
    ),
    "carmen_corrected_logs/freiburg-101-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/freiburg-101-corrected.log.gz",
        "7792de88bcb050f8edba92914aea75e8ec2fb73b483c01903bd2753aa655e982",
        False,
    ),
    "carmen_corrected_logs/freiburg-campus-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/freiburg-campus-corrected.log.gz",
        "534fae978c3a28fd9994c9b3327a36a2752df8339e232b9b70f96f67f76341b0",
        False,
    ),
    "carmen_corrected_logs/infinite-corridor-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/infinite-corridor-corrected.log.gz",
        "6a63c51eb97aa4e720fe207e91f926c283f77b4c534903983f9c5a6cbed6ebc4",
        False,
    ),
    "carmen_corrected_logs/intel-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/intel-corrected.log.gz",
        "71bef16e9926506cf7417995ef35ace09dbd5de067fd042a3aab85188b5480dc",
        False,
    ),
    "carmen_corrected_logs/orebro-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/orebro-corrected.log.gz",
        "39a189c64489b84996669bc484d6bd6864f8733029a280a0e549a0adaae08a82",
        False,
    ),
    "carmen_corrected_logs/seattle-corrected.log.gz": (
        "acschaefer/ple/cfcb5a7f12a793b616357381a688cfcc26eed347/data/carmen/seattle-corrected.log.gz",
        "5719198036b788d78a877ca04efdbfb07c2518508310f51d49c198bf1956bb4b",
        False,
    ),
    "victoria_park/victoriaPark_isam.txt": (
        "rickytan/iSAM/617b3ff154419f92d28e689a0f873d15cd999efe/data/victoriaPark.txt",
        "7bb524560f3050163f8af9c4f07ca5a75f6fd0d0a65112c06bf698b7f0680cee",
        False,
    ),
    "victoria_park/victoria_park_gtsam.txt": (
        "borglab/gtsam/0ffe6c930302ebd297484e65e6e8d467c91d26b0/examples/Data/victoria_park.txt",
        "10596bac625acfe009080748b0ec9993fc9925a93370878c20288a22eeee5253",
        False,
    ),
    "acfr_carpark/data_set.mat": (
        "yuzehai1995/hwork_SLAM/b4715234d795a5dd8155371e99b71f99803eb551/hw4_slam/data_set.mat",
        "f44c8adfa7e8e38ea6c40da3cd5d52bd8e029fc2d5ea27a9d7df24ad4ec98be7",
        False,
    ),
    "acfr_carpark/beac_juan3.mat": (
        "yuzehai1995/hwork_SLAM/b4715234d795a5dd8155371e99b71f99803eb551/hw4_slam/beac_juan3.mat",
        "a6def97aef0e0f0d7a0a00f7014cdd1390fd8779ec7f17613c32b2e44aae1f36",
        False,
    ),
}


class FetchError(UserError, RuntimeError):
    """A download failed or did not match its pinned sha256 (nothing is stored then)."""


def url_of(relative: str) -> str:
    return RAW + FILES[relative][0]


def _downloader():
    """The pooch downloader (``None``: pooch's HTTP default). Tests replace this function."""
    return None


def fetch(name: str, force: bool = False) -> list[Path]:
    """Download the files of catalogue entry ``name`` into the cache data root, unless some place already holds all of
    them (a dataset is read from one place: a file or two fetched beside another root's files would not be read);
    return the paths of its files."""
    import pooch

    from .catalogue import CATALOGUE
    from .registry import resolve

    dataset = resolve(name)
    if name not in CATALOGUE:
        raise FetchError(f"{name}: only a catalogued dataset can be fetched (slamarena data list)")
    if not CATALOGUE[name].fetchable:
        raise FetchError(f"{name}: staged only (a folder of images with no pinned download); see its SOURCE.md")
    if not force and dataset.present():
        return list(dataset.files().values())
    pinned = {role: [c for c in candidates if c in FILES] for role, candidates in dataset.layout.files.items()}
    unknown = [role for role, rels in pinned.items() if len(rels) > 1 or not rels and role in dataset.layout.required()]
    if unknown:
        raise FetchError(
            f"{name}: no pinned download for {', '.join(' or '.join(dataset.layout.files[r]) for r in unknown)}"
        )
    out = []
    for rel in (rels[0] for rels in pinned.values() if rels):
        target = cache_dir() / rel
        if target.is_file() and not force:
            out.append(target)
            continue
        upstream, sha256, compressed = FILES[rel]
        staging = cache_dir() / ".downloads" / Path(rel).parent
        fname = Path(upstream).name
        try:
            got = pooch.retrieve(
                RAW + upstream,
                known_hash=f"sha256:{sha256}",
                fname=fname,
                path=staging,
                downloader=_downloader(),
                progressbar=False,
            )
        except ValueError as exc:  # pooch's hash mismatch
            raise FetchError(f"{name}: {rel} does not match its pinned sha256 ({exc})") from exc
        except Exception as exc:  # network errors of any kind
            raise FetchError(f"{name}: download of {RAW + upstream} failed: {exc}") from exc
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(target.name + ".part")
        if compressed:
            with open(got, "rb") as src, gzip.GzipFile(tmp, "wb", compresslevel=9, mtime=0) as dst:
                shutil.copyfileobj(src, dst)
        else:
            shutil.copyfile(got, tmp)
        tmp.replace(target)
        Path(got).unlink()
        out.append(target)
    return out
