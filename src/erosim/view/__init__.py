"""erosim.view: look at a finished run — the offline browser view (``erosim view``) and the exports
artists import (``erosim export``). It reads run folders with :mod:`erosim.io.results`, draws with
:mod:`erosim.viz` and writes with :mod:`erosim.io.exports`; nothing here runs a simulation."""
