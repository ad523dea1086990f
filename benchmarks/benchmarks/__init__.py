"""bathprint's regression benchmarks for airspeed velocity (asv): see benchmarks/README.md."""
