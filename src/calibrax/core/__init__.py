"""The core: interfaces, values, the search and the store. It never imports a backend."""
