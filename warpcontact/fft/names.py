"""The names of the FFT backends and the devices they run on: plain data, no Warp, so that the case
(warpcontact.records.case) and the command line's parser can name them without loading a backend."""

#: FFT backends by name ("auto": the fastest available on the device; see warpcontact.fft)
BACKENDS = ("auto", "fftw", "scipy", "cupy", "warp")
#: FFT backends that run only on one kind of device ("cpu" or "cuda"); the others run on both
DEVICE_KIND = {"fftw": "cpu", "scipy": "cpu", "cupy": "cuda"}
