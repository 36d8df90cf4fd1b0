from app.analysis.example import main


def test_shipped_example_is_reproducible(tmp_path, repo_root):
    main(str(tmp_path / "votes.csv"))
    assert (tmp_path / "votes.csv").read_text() == (
        repo_root / "app" / "data" / "examples" / "votes.csv"
    ).read_text()
