"""The camera path: two-view geometry, triangulation, PnP, descriptor matching (the notes' Phase 4).

Every pose is ``T_cam←world = (R, t)`` (x_c = R X + t) and image points are pixels u (n, 2) or normalised
coordinates x = ((u − cx)/fx, (v − cy)/fy) (n, 2); camera axes x right, y down, z forward. Modules:

``lie``            SO(3)/SE(3) exp and log, the left perturbation used by every refinement
``projection``     pinhole projection, reprojection residuals and their Jacobians; the radial pixel distortion
``triangulation``  linear DLT and midpoint triangulation
``two_view``       5-point and normalised 8-point essential matrix, decomposition, cheirality, RANSAC
``pnp``            P3P, EPnP, RANSAC with an adaptive number of samples, Levenberg-Marquardt on SE(3)
``matching``       Hamming-distance matching of binary descriptors, ratio test, mutual check
``ransac``         the adaptive number of RANSAC iterations

ORB detection and description are OpenCV's (not the object of study).
"""
