# Sourced by the sanitizer and aarch64 jobs (scripts/test_sanitized.sh, test_aarch64.sh):
# `statistical`, a ctest regular expression of the statistical comparisons over every scene,
# which those jobs leave to the native run. Each renders every scene many times over (under
# the sanitizers about 220 s of 1,190 s of tests; under qemu 245 s of 1,410 s), and checks
# estimators whose code is the same C++ on every ISA, while the code they run (every
# estimator, both integrators, the samplers) runs in both jobs in the smaller tests that
# compare them on a few scenes (Bidirectional.ScalarAndWavefrontAgree, VcmFindsACaustic...,
# Estimators.Irradiance..., Agreement.WavefrontMatchesScalarOnEverySceneAndIsa: the kernels
# of each ISA against the scalar reference on every scene).
statistical='^(Bidirectional\.(AgreesWithMis|VcmAgreesWithMis|BpmAndPpmAgreeWithMisInMean)OnEveryScene'
statistical+='|Estimators\.AgreeWithinThreeSigmaOnEveryScene'
statistical+='|Converge\.(AFivePercentBiasStandsAboveTheNoise|ALowerSurvivalCapCostsAccuracy|MseFallsAsOneOverPathsPerPixel)'
statistical+='|GuidedRender\.AgreesWithMisPerPixelOnEveryScene'
# (and the guided renders killed under MPI: the ranks' guide exchange runs in the smaller
# Mpi.AGuidedRenderContinuedOnOtherRanksGivesTheOneProcessImage)
statistical+='|Checkpoints\.AGuidedRenderKilledUnder.*)$'
