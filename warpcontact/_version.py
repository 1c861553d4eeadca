"""The package's version, recorded in every result (result.json, a sweep's and a fit's records):
a module of its own, below every other, so that the studies read it without importing the
package's entry points (warpcontact/__init__.py re-exports it)."""

__version__ = "0.1.0"
